// evermap-map-export's parts (tools/map-export): the occupancy grid from synthetic points, the
// map_server files, the stores read without a byte changed, and plans that follow the graph.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <evermap/keyframe_t.hpp>

#include "core/bow/place_store.h"
#include "core/map/store_file.h"
#include "core/map/store_reader.h"
#include "tests/scratch_dir.h"
#include "tests/scripted_drive.h"
#include "tools/map-export/floor_plans.h"
#include "tools/map-export/map_scans.h"
#include "tools/map-export/occupancy_grid.h"

namespace evermap::map_export {
namespace {

using core::SE3d;
using core::Vec3;

// A wall of points across x = wall_x (|y| <= 1, z in [0.2, 1.4]) seen from `camera`.
Scan wallScan(const Vec3& camera, double wall_x) {
  Scan s;
  s.camera = camera;
  for (double y = -1.0; y <= 1.0; y += 0.02)
    for (double z = 0.2; z <= 1.4; z += 0.2) s.points.emplace_back(wall_x, y, z);
  return s;
}

TEST(OccupancyGrid, AWallSeenFromACameraIsOccupiedWithFreeSpaceInFrontAndUnknownBehind) {
  GridOptions o;
  const Scan scan = wallScan(Vec3(0, 0, 1.0), 3.0);
  OccupancyGrid g = OccupancyGrid::covering({scan}, o);
  g.addScan(scan, 0.0, o);
  int i = 0, j = 0;
  ASSERT_TRUE(g.cellOf(3.01, 0.0, &i, &j));
  EXPECT_EQ(g.cell(i, j), Cell::kOccupied);
  ASSERT_TRUE(g.cellOf(1.5, 0.0, &i, &j));
  EXPECT_EQ(g.cell(i, j), Cell::kFree);
  ASSERT_TRUE(g.cellOf(3.5, 0.0, &i, &j));
  EXPECT_EQ(g.cell(i, j), Cell::kUnknown);
  ASSERT_TRUE(g.cellOf(1.5, 0.4, &i, &j));  // inside the fan of rays (|y| <= x / 3)
  EXPECT_EQ(g.cell(i, j), Cell::kFree);
  ASSERT_TRUE(g.cellOf(-0.5, 0.0, &i, &j));  // behind the camera
  EXPECT_EQ(g.cell(i, j), Cell::kUnknown);
}

TEST(OccupancyGrid, PointsAboveTheRobotsBandAreNoObstacle) {
  GridOptions o;
  o.band_max_m = 1.0;
  Scan scan;
  scan.camera = Vec3(0, 0, 0.8);
  for (double y = -0.5; y <= 0.5; y += 0.02) scan.points.emplace_back(2.0, y, 2.0);
  OccupancyGrid g = OccupancyGrid::covering({scan}, o);
  g.addScan(scan, 0.0, o);
  for (int j = 0; j < g.height(); ++j)
    for (int i = 0; i < g.width(); ++i) EXPECT_NE(g.cell(i, j), Cell::kOccupied);
}

TEST(OccupancyGrid, WritesMapServersImageAndYaml) {
  GridOptions o;
  o.resolution_m = 0.1;
  const Scan scan = wallScan(Vec3(0, 0, 1.0), 2.0);
  OccupancyGrid g = OccupancyGrid::covering({scan}, o);
  g.addScan(scan, 0.0, o);
  const std::string pgm = g.pgm();
  const std::string header =
      "P5\n" + std::to_string(g.width()) + " " + std::to_string(g.height()) + "\n255\n";
  ASSERT_EQ(pgm.substr(0, header.size()), header);
  EXPECT_EQ(pgm.size(), header.size() + static_cast<size_t>(g.width()) * g.height());
  // The image's top row is the largest y: the wall cell at (2, 0) is at row height-1-j.
  int i = 0, j = 0;
  ASSERT_TRUE(g.cellOf(2.01, 0.0, &i, &j));
  EXPECT_EQ(static_cast<uint8_t>(pgm[header.size() + (g.height() - 1 - j) * g.width() + i]), 0);
  const std::string yaml = g.yaml("floor-0.pgm");
  for (const char* field : {"image: floor-0.pgm", "resolution: 0.100000", "negate: 0",
                            "occupied_thresh: 0.65", "free_thresh: 0.196", "origin: ["})
    EXPECT_NE(yaml.find(field), std::string::npos) << field << " in\n" << yaml;
  char origin[80];
  std::snprintf(origin, sizeof origin, "origin: [%.6f, %.6f, 0.0]", g.x0(), g.y0());
  EXPECT_NE(yaml.find(origin), std::string::npos);
}

// The camera looks along the body's x axis, 1 m above the body origin (camera z forward,
// x right, y down).
SE3d bodyTCam() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return SE3d(Eigen::Quaterniond(R), Vec3(0, 0, 1.0));
}

// A keyframe whose points are a wall `depth` metres ahead of the camera.
evermap::keyframe_t wallKeyframe(int64_t utime, double depth) {
  evermap::keyframe_t k{};
  k.utime = utime;
  k.fx = k.fy = 400;
  k.cx = 320;
  k.cy = 240;
  k.baseline_m = 0.1;
  for (double x = -0.98; x <= 1.0; x += 0.05)
    for (double y = -0.3; y <= 0.7; y += 0.25) {
      k.keypoints.push_back(
          {static_cast<float>(320 + 400 * x / depth), static_cast<float>(240 + 400 * y / depth)});
      k.points.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(depth)});
      k.disparity.push_back(static_cast<float>(400 * 0.1 / depth));
      k.level.push_back(0);
      k.descriptors.emplace_back(32, 0);
    }
  k.num_features = static_cast<int32_t>(k.points.size());
  return k;
}

map::MapSnapshot oneNodeMap(const SE3d& world_T_body) {
  map::MapSnapshot m;
  map::StoredNode n;
  n.node.keyframe_utime = 100;
  n.world_T_body = world_T_body;
  m.nodes.push_back(n);
  return m;
}

std::vector<std::pair<int, int>> occupiedCells(const OccupancyGrid& g) {
  std::vector<std::pair<int, int>> out;
  for (int j = 0; j < g.height(); ++j)
    for (int i = 0; i < g.width(); ++i)
      if (g.cell(i, j) == Cell::kOccupied) {
        const core::Vec2 c = g.centre(i, j);
        out.emplace_back(static_cast<int>(std::floor(c.x() / g.resolution())),
                         static_cast<int>(std::floor(c.y() / g.resolution())));
      }
  return out;
}

std::string bytesOf(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(MapExport, ReadsBothStoresWithoutChangingAByteAndCountsNodesWithoutAKeyframe) {
  evermap::testing::ScratchDir dir;
  const auto map_file = dir / "map.db", places_file = dir / "places.db";
  mapper::testing::ScriptedDrive drive(mapper::MapperOptions{});
  drive.driveTo(6.0, 0.0);
  {
    auto store = mapper::MapStore::open(map_file);
    ASSERT_TRUE(store) << store.error().message;
    ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  }
  const auto& nodes = drive.mapper().nodes();
  ASSERT_GE(nodes.size(), 3u);
  {
    auto places = bow::PlaceStore::open(places_file, 1234, 10);
    ASSERT_TRUE(places) << places.error().message;
    std::vector<evermap::keyframe_t> frames;
    for (size_t k = 0; k + 1 < nodes.size(); ++k)  // the last node's keyframe is missing
      frames.push_back(wallKeyframe(nodes[k].keyframe_utime, 3.0));
    frames[1].points[0][0] = std::numeric_limits<float>::quiet_NaN();  // and one is broken
    ASSERT_TRUE(places->saveKeyframes(frames));
  }
  const std::string map_before = bytesOf(map_file), places_before = bytesOf(places_file);
  auto file = map::StoreFile::open(map_file, /*read_only=*/true);
  ASSERT_TRUE(file) << file.error().message;
  auto snapshot = map::readMap(*file);
  ASSERT_TRUE(snapshot) << snapshot.error().message;
  auto keyframes = KeyframeReader::open(places_file);
  ASSERT_TRUE(keyframes) << keyframes.error().message;
  const ScanSet scans = loadScans(*snapshot, *keyframes, bodyTCam());
  EXPECT_EQ(scans.errors, 2);
  EXPECT_EQ(scans.nodes.size(), nodes.size() - 2);
  ASSERT_EQ(scans.messages.size(), 2u);
  EXPECT_NE(scans.messages[1].find("not in the place store"), std::string::npos);
  const auto plans = makeFloorPlans(scans, GridOptions{});
  ASSERT_EQ(plans.size(), 1u);
  auto written = writeExport(dir / "out", *snapshot, scans, plans, GridOptions{}.max_range_m);
  ASSERT_TRUE(written) << written.error().message;
  for (const char* name : {"floor-0.pgm", "floor-0.yaml", "nodes.csv", "edges.csv", "points.ply"})
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / name)) << name;
  EXPECT_EQ(bytesOf(map_file), map_before);
  EXPECT_EQ(bytesOf(places_file), places_before);
  EXPECT_FALSE(KeyframeReader::open(dir / "none.db"));
}

TEST(MapExport, ThePlanFollowsTheGraphWhenANodeMoves) {
  evermap::testing::ScratchDir dir;
  {
    auto places = bow::PlaceStore::open(dir / "places.db", 1234, 10);
    ASSERT_TRUE(places) << places.error().message;
    const evermap::keyframe_t k = wallKeyframe(100, 3.02);
    ASSERT_TRUE(places->saveKeyframes(std::span<const evermap::keyframe_t>(&k, 1)));
  }
  auto keyframes = KeyframeReader::open(dir / "places.db");
  ASSERT_TRUE(keyframes) << keyframes.error().message;
  GridOptions o;
  o.resolution_m = 0.1;
  auto plan = [&](const SE3d& pose) {
    const ScanSet scans = loadScans(oneNodeMap(pose), *keyframes, bodyTCam());
    EXPECT_EQ(scans.errors, 0);
    return occupiedCells(makeFloorPlans(scans, o).at(0).grid);
  };
  const auto before = plan(SE3d());
  ASSERT_FALSE(before.empty());
  for (const auto& [i, j] : before) EXPECT_EQ(i, 30);  // the wall at x = 3.02
  // A loop closure moved the node 1 m along y and 0.5 m along x: the wall moves with it.
  const auto after = plan(SE3d(core::SO3d(), Vec3(0.5, 1.0, 0.0)));
  ASSERT_EQ(after.size(), before.size());
  for (size_t k = 0; k < after.size(); ++k) {
    EXPECT_EQ(after[k].first, before[k].first + 5);
    EXPECT_EQ(after[k].second, before[k].second + 10);
  }
}

}  // namespace
}  // namespace evermap::map_export

namespace evermap::map_export {
namespace {

TEST(MapExport, ABodyThatIsTheCameraHasItsMinusYAxisUp) {
  const core::SE3d plan_T_map = planTMap(UpAxis::kMinusY);
  EXPECT_TRUE((plan_T_map * core::Vec3(0, -1, 0)).isApprox(core::Vec3(0, 0, 1)));
  EXPECT_TRUE((plan_T_map * core::Vec3(0, 0, 1)).isApprox(core::Vec3(0, 1, 0)));  // ahead
  EXPECT_TRUE((planTMap(UpAxis::kZ) * core::Vec3(1, 2, 3)).isApprox(core::Vec3(1, 2, 3)));
}

}  // namespace
}  // namespace evermap::map_export
