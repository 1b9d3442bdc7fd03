// evermap-map-export: a built map's floor plans for a navigation stack (docs/floor-plans.md):
// per floor an occupancy grid in ROS map_server's format, the nodes and edges as CSV and the
// keyframe points as PLY, from the map store and loopclose-proc's place store, both read-only.
// With --truth, the plans are scored against the image-level simulator's walls.
// Exit status: 0 written (nodes left out are counted and named on stderr), 1 bad input,
// 2 bad command line.

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/common/option_fields.h"
#include "core/map/store_reader.h"
#include "tools/map-export/camera_mounting.h"
#include "tools/map-export/floor_plans.h"
#include "tools/map-export/map_scans.h"
#include "tools/map-export/truth_plan.h"

namespace {

using namespace evermap;

int fail(const std::string& message, int code = 1) {
  std::fprintf(stderr, "evermap-map-export: %s\n", message.c_str());
  return code;
}

struct ExportOptions {
  map_export::GridOptions grid;
  double truth_tolerance_m = 0.10;
  map_export::UpAxis up = map_export::UpAxis::kZ;
  void declareOptions(OptionList& o) {
    o.nest("grid.", &grid);
    o.choice("up", &up, {{"z", map_export::UpAxis::kZ}, {"-y", map_export::UpAxis::kMinusY}},
             "up in the map frame: z (a gravity-aligned body: IMU) or -y (the body is the "
             "camera, y down: evermap-kitti2lcm)");
    o.add("truth_tolerance_m", &truth_tolerance_m, "m",
          "--truth: an occupied cell this close to a true wall is right")
        .positive();
  }
};

struct ExportArgs {
  std::string store, places, out, calib, truth, truth_nodes;
  std::vector<std::string> truth_sets;
  ExportOptions options;
};

int parseCommandLine(int argc, char** argv, ExportArgs* a) {
  CommandLine cli("evermap-map-export",
                  "Floor plans (map_server PGM + YAML), nodes/edges CSV and a PLY point cloud "
                  "of a map, from its map store and place store (both read-only).");
  cli.value("--store", &a->store, "MAP.db", "the map store (mapper-proc --store)", true);
  cli.value("--places", &a->places, "PLACES.db",
            "loopclose-proc's place store (its --store; slam-run --places)", true);
  cli.value("--out", &a->out, "DIR", "output folder (created)", true);
  cli.value("--calib", &a->calib, "LOG",
            "an LCM log of the camera: its first STEREO_CALIB or RGBD_CALIB gives body_T_cam");
  cli.value("--truth", &a->truth, "SIM-IMAGE.conf",
            "score the plans against this simulator config's building (its camera gives "
            "body_T_cam when --calib is not given)");
  cli.repeated("--truth-set", &a->truth_sets, "KEY=VALUE", "override one --truth setting");
  cli.value("--truth-nodes", &a->truth_nodes, "NODES.csv",
            "with --truth: evermap-slam-run's nodes.csv (the nodes' true positions)");
  cli.options(&a->options);
  cli.alias("--resolution", "grid.resolution_m", "M");
  cli.alias("--band-min", "grid.band_min_m", "M");
  cli.alias("--band-max", "grid.band_max_m", "M");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->calib.empty() && a->truth.empty())
    return fail("give --calib LOG (or --truth SIM.conf) for the camera's mounting\n" + cli.usage(),
                2);
  if (!a->truth.empty() && a->truth_nodes.empty())
    return fail("--truth needs --truth-nodes\n" + cli.usage(), 2);
  if (Status s = a->options.grid.validate(); !s) return fail(s.error().message, 2);
  return -1;
}

// The truth's simulator settings (none without --truth); -1, else the exit status.
int loadTruth(const ExportArgs& a, std::optional<sim::ImageSimOptions>* out) {
  if (a.truth.empty()) return -1;
  auto o = sim::loadConfig(sim::loadImageSimOptions, a.truth, a.truth_sets, "--truth-set");
  if (!o) return fail(o.error().message, 2);
  *out = *o;
  return -1;
}

int score(const ExportArgs& a, const sim::ImageSimOptions& sim,
          const std::vector<map_export::FloorPlan>& plans, const map_export::ScanSet& scans) {
  auto truth = map_export::BuildingTruth::load(sim, a.truth_nodes);
  if (!truth) return fail(truth.error().message);
  auto c = truth->compare(plans, scans, a.options.truth_tolerance_m);
  if (!c) return fail(c.error().message);
  std::printf("%s", c->text().c_str());
  for (const map_export::FloorPlan& p : plans) {
    const std::string name = a.out + "/floor-" + std::to_string(p.floor) + "-truth.png";
    if (Status s = truth->drawFloor(p, *c, name); !s) return fail(s.error().message);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ExportArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  std::optional<sim::ImageSimOptions> sim;
  if (const int code = loadTruth(a, &sim); code >= 0) return code;
  const auto t0 = std::chrono::steady_clock::now();
  core::SE3d body_T_cam;
  if (!a.calib.empty()) {
    auto m = map_export::mountingFromLog(a.calib);
    if (!m) return fail(m.error().message);
    body_T_cam = *m;
  } else {
    body_T_cam = sim->sim.sensors.camera.bodyTCam();
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(a.store, ec))
    return fail(a.store + ": no such map store (--store)");
  auto store = map::StoreFile::open(a.store, /*read_only=*/true);
  if (!store) return fail(store.error().message);
  auto snapshot = map::readMap(*store);
  if (!snapshot) return fail(snapshot.error().message);
  auto keyframes = map_export::KeyframeReader::open(a.places);
  if (!keyframes) return fail(keyframes.error().message);
  const map_export::ScanSet scans =
      map_export::loadScans(*snapshot, *keyframes, body_T_cam, map_export::planTMap(a.options.up));
  for (const std::string& m : scans.messages) fail(a.store + ": " + m);
  const auto plans = map_export::makeFloorPlans(scans, a.options.grid);
  auto written =
      map_export::writeExport(a.out, *snapshot, scans, plans, a.options.grid.max_range_m);
  if (!written) return fail(written.error().message);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "%s: %zu floors, %zu of %zu nodes (%lld left out), %lld points, %lld files, "
      "%lld bytes, %.2f s\n",
      a.out.c_str(), plans.size(), scans.nodes.size(), snapshot->nodes.size(),
      static_cast<long long>(scans.errors), static_cast<long long>(written->points),
      static_cast<long long>(written->files), static_cast<long long>(written->bytes), seconds);
  if (auto b = keyframes->keyframeBytes(); b && b->first > 0)
    std::printf("place store keyframes: %lld, %lld bytes of messages (%.0f per keyframe)\n",
                static_cast<long long>(b->first), static_cast<long long>(b->second),
                double(b->second) / b->first);
  if (sim) return score(a, *sim, plans, scans);
  return 0;
}
