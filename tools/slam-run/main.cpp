// evermap-slam-run: the whole visual SLAM system in one process over LCM logs, one log per
// session (tools/slam-run/slam_runner.h): the map store, the live trajectory (TUM), per-frame
// CSV and a summary with the evaluation against GROUND_TRUTH where the logs have it.
// Exit status: 0 done, 1 bad input (a log, the vocabulary, the store), 2 bad command line.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/bow/vocabulary_io.h"
#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/common/option_fields.h"
#include "mapper-proc/mapper_config.h"
#include "tools/eval/alignment.h"
#include "tools/eval/plot.h"
#include "tools/eval/trajectory.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/sim/image_sim_options.h"
#include "tools/slam-run/localize_runner.h"
#include "tools/slam-run/slam_runner.h"

namespace {

void report(const evermap::Status& s) {
  if (!s) std::fprintf(stderr, "evermap-slam-run: plot: %s\n", s.error().message.c_str());
}

// The paper's Fig. 4 (the map's nodes against the ground truth: top view, and floors stacked)
// and Fig. 7 (nodes, and time per component, against operating time), from this run.
void writeFigures(const std::filesystem::path& dir,
                  const evermap::slam_run::SlamRunSummary& summary,
                  const std::vector<evermap::slam_run::SlamRunner::FrameRow>& frames,
                  bool full_graph) {
  using namespace evermap;
  const std::string graph = full_graph ? "full" : "reduced";
  if (summary.node_rows.size() >= 3) {
    std::vector<core::Vec3> gt, est;
    for (const auto& n : summary.node_rows) {
      gt.push_back(n.truth);
      est.push_back(n.estimate);
    }
    if (auto a = eval::umeyama(est, gt, false)) {
      for (core::Vec3& p : est) p = a->gt_S_est * p;
      eval::TopViewOptions top;
      top.title = "Fig. 4: " + graph +
                  " pose graph from pixels (evermap-slam-run), map nodes against ground truth";
      char sub[200];
      std::snprintf(sub, sizeof sub, "%zu nodes, %zu sessions, node ATE rmse %.3f m", gt.size(),
                    summary.sessions.size(),
                    summary.evaluation ? summary.evaluation->ate_rmse_m : -1.0);
      top.subtitle = sub;
      top.gt_label = "nodes, ground truth";
      top.est_label = "nodes, estimate";
      top.plane = eval::PlotPlane::kXY;
      report(eval::writeTopView(dir / "fig4-nodes.png", gt, est, top));
      // Floors stacked: an oblique view (u = x + 0.5 y, v = 0.35 y + 3 z) as in the paper's figure.
      auto oblique = [](std::vector<core::Vec3> pts) {
        for (core::Vec3& p : pts)
          p = core::Vec3(p.x() + 0.5 * p.y(), 0.35 * p.y() + 3.0 * p.z(), 0.0);
        return pts;
      };
      top.title = "Fig. 4: " + graph + " pose graph from pixels, floors stacked (oblique)";
      report(eval::writeTopView(dir / "fig4-floors.svg", oblique(gt), oblique(est), top));
    }
  }
  if (frames.empty()) return;
  // Per minute of operation: nodes at its end, and milliseconds of work per second.
  eval::ChartSeries nodes{"nodes", {}, {214, 39, 40}, false};
  eval::ChartSeries vo{"VO (rectify, features, odometry, descriptors)", {}, {31, 119, 180}, false};
  eval::ChartSeries lc{"loop closing (BoW query, registration)", {}, {44, 160, 44}, false};
  eval::ChartSeries mp{"mapper (tracking, steps, solver, store)", {}, {214, 39, 40}, false};
  size_t i = 0;
  while (i < frames.size()) {
    const int minute = static_cast<int>(frames[i].run_s / 60.0);
    double vo_ms = 0, lc_ms = 0, mp_ms = 0;
    int64_t n = 0;
    for (; i < frames.size() && static_cast<int>(frames[i].run_s / 60.0) == minute; ++i) {
      vo_ms += frames[i].vo_ms;
      lc_ms += frames[i].loopclose_ms;
      mp_ms += frames[i].mapper_ms;
      n = frames[i].nodes;
    }
    const double h = (minute + 1) / 60.0;
    nodes.points.emplace_back(h, static_cast<double>(n));
    vo.points.emplace_back(h, vo_ms / 60.0);
    lc.points.emplace_back(h, lc_ms / 60.0);
    mp.points.emplace_back(h, mp_ms / 60.0);
  }
  eval::LineChartOptions o;
  o.x_label = "operating time [h] (sessions end to end)";
  o.title = "Fig. 7 (bottom): nodes in the " + graph + " graph against operating time, from pixels";
  o.y_label = "nodes";
  report(eval::writeLineChart(dir / "fig7-nodes.svg", {nodes}, o));
  o.title = "Fig. 7 (top): time per component, per minute of operation, from pixels";
  o.y_label = "ms per s";
  report(eval::writeLineChart(dir / "fig7-components.svg", {vo, lc, mp}, o));
}

// The command line of a run.
struct SlamArgs {
  evermap::slam_run::SlamRunOptions options;
  std::string vocab_file, out_dir, config;
  std::vector<std::string> logs, sets, render_sets;
  std::string render_config, localize;
  int render_sessions = -1;
  bool full_graph = false, print_config = false, places = false;
};

int fail(const std::string& what, int code) {
  std::fprintf(stderr, "evermap-slam-run: %s\n", what.c_str());
  return code;
}

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, SlamArgs* a) {
  evermap::CommandLine cli(
      "evermap-slam-run",
      "The visual SLAM system in one process: LCM logs (one per session) in, a map out.");
  cli.value("--vocab", &a->vocab_file, "FILE",
            "vocabulary (evermap-vocab-train .evoc, or DBoW2/3 .yml.gz; required)");
  cli.value("--out", &a->out_dir, "DIR",
            "output folder: map.db, trajectory.tum, frames.csv, registrations.csv, nodes.csv, "
            "summary.txt, fig4-nodes.png, fig4-floors.svg, fig7-*.svg "
            "(created; an existing map.db is "
            "continued as a stored map; required)");
  cli.flag("--places", &a->places,
           "write loopclose-proc's place store to DIR/places.db as well "
           "(the node keyframes evermap-map-export reads; an existing one is continued)");
  cli.value("--localize", &a->localize, "MAPDIR",
            "localize one session (one log, or --render's render.session) against the map of "
            "an earlier run with --places (MAPDIR/map.db, places.db; both read-only, unchanged) "
            "instead of mapping: DIR/localization.csv and localize-summary.txt, scored against "
            "the truth with MAPDIR/nodes.csv when there is one (docs/localization.md)");
  cli.flag("--full-graph", &a->full_graph,
           "a node at every step (the paper's baseline) instead of the reduced graph");
  cli.value("--config", &a->config, "MAPPER.conf",
            "mapper.* settings (docs/mapper.md), and vo.* ones (vo-proc's: evermap-vo-proc "
            "--print-config; e.g. vo.odometry.line_delay_us, docs/rgbd.md)");
  cli.repeated("--set", &a->sets, "mapper.KEY=VALUE", "override one mapper.* or vo.* setting");
  cli.value("--max-session-s", &a->options.max_session_s, "S",
            "map at most S seconds of each log (0: all)")
      .min(0);
  cli.value("--start-s", &a->options.start_session_s, "S",
            "with --localize: begin S seconds into the session, as a robot switched on there "
            "(another floor, mid-corridor); --max-session-s counts from there")
      .min(0);
  cli.value("--drop-frames", &a->options.drop.fraction, "F",
            "drop this fraction of the frames before VO, as vo-proc drops them under load: "
            "single frames, and 30 % of the drops bursts of 5 frames (seeded)")
      .in(0, 0.5);
  cli.value("--drop-seed", &a->options.drop.seed, "N", "seed of --drop-frames").min(0);
  cli.value(
      "--drop-utimes",
      [a](const std::string& file) -> evermap::Status {
        auto utimes = evermap::slam_run::readDroppedFrames(file);
        if (!utimes) return utimes.error();
        a->options.drop.utimes.insert(a->options.drop.utimes.end(), utimes->begin(), utimes->end());
        return evermap::Ok{};
      },
      "FILE",
      "drop the frames a live vo-proc dropped behind its queue: its log's \"dropped behind the "
      "queue: frame U\" lines (a deputy's vo-proc.log as it is), or one frame time a line "
      "(repeatable)");
  cli.value("--render", &a->render_config, "SIM-IMAGE.conf",
            "render the image-level simulator's sessions on the fly instead of reading logs "
            "(config/sim-image-*.conf)");
  cli.repeated("--render-set", &a->render_sets, "KEY=VALUE",
               "override one setting of the --render file");
  cli.value("--sessions", &a->render_sessions, "N",
            "with --render: sessions 0 .. N-1 (default: patrol.sessions)")
      .min(1);
  cli.flag("--print-config", &a->print_config,
           "print the mapper's and VO's settings in effect (and the --render file's) and exit");
  cli.positional(&a->logs, "LOG...", "LCM logs, mapped as successive sessions");
  // The keys --config and --set take, listed in --help.
  evermap::mapper::MapperOptions listed;
  cli.options(&listed, "mapper.");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->print_config) return -1;
  for (const auto& [flag, value] : {std::pair{"--vocab", &a->vocab_file}, {"--out", &a->out_dir}}) {
    if (value->empty()) return fail(std::string(flag) + " is required\n" + cli.usage(), 2);
  }
  if (a->logs.empty() == a->render_config.empty())
    return fail("give either LCM logs or --render\n" + cli.usage(), 2);
  return -1;
}

// The image-level simulator's settings of --render (none without it), and the number of
// sessions to render into a->render_sessions; -1, else the exit status.
int loadRender(SlamArgs* a, std::optional<evermap::sim::ImageSimOptions>* render) {
  using namespace evermap;
  if (a->render_config.empty()) return -1;
  auto file = KeyValueFile::load(a->render_config, a->render_sets, "--render-set");
  if (!file) return fail(file.error().message, 2);
  auto o = sim::loadImageSimOptions(*file);
  if (!o) return fail(o.error().message, 2);
  if (a->render_sessions < 0) a->render_sessions = o->sim.patrol.sessions;
  if (a->render_sessions < 1 || a->render_sessions > o->sim.patrol.sessions)
    return fail(
        "--sessions: must be 1 .. patrol.sessions (" + std::to_string(o->sim.patrol.sessions) + ")",
        2);
  *render = *o;
  return -1;
}

// The mapper's and VO's options from --config and --set (mapper.* and vo.* keys); -1, else the
// exit status.
int loadMapperOptions(SlamArgs* a) {
  using namespace evermap;
  auto settings =
      a->config.empty() ? KeyValueFile::parse("", "--set") : KeyValueFile::load(a->config);
  if (settings) {
    if (Status s = settings->setAll(a->sets, "--set"); !s) settings = s.error();
  }
  if (!settings) return fail(settings.error().message, 2);
  const KeyValueFile vo = settings->extract("vo.");
  if (Status s = OptionList::of(&a->options.vo, "vo.").load(vo); !s)
    return fail(s.error().message, 2);
  if (Status s = a->options.vo.validate(); !s) return fail(s.error().message, 2);
  if (Status s = mapper::readMapperOptions(*settings, &a->options.mapper); !s)
    return fail(s.error().message, 2);
  a->options.mapper.full_graph = a->full_graph;
  return -1;
}

// frames.csv, registrations.csv and nodes.csv of the run.
evermap::Status writeTables(const std::filesystem::path& out,
                            const evermap::slam_run::SlamRunner& runner,
                            const evermap::slam_run::SlamRunSummary& summary) {
  using evermap::writeFileAtomically;
  std::ostringstream csv;
  csv << "utime,session,run_s,vo_status,inliers,vo_ms,loopclose_ms,mapper_ms,nodes\n";
  for (const auto& f : runner.frames())
    csv << f.utime << "," << f.session << "," << f.run_s << "," << f.vo_status << "," << f.inliers
        << "," << f.vo_ms << "," << f.loopclose_ms << "," << f.mapper_ms << "," << f.nodes << "\n";
  if (auto s = writeFileAtomically(out / "frames.csv", csv.str()); !s) return s;
  std::ostringstream reg;
  reg << "query_utime,mode,status,node,node_keyframe_utime,inliers,score,error_m,error_deg,nees,"
         "outcome,active,"
         "delta_error_m,delta_error_deg,delta_nees,requested_node,requested_keyframe_utime\n";
  for (const auto& r : runner.registrations())
    reg << r.query_utime << "," << r.mode << "," << r.status << "," << r.node << ","
        << r.node_keyframe_utime << "," << r.inliers << "," << r.score << "," << r.error_m << ","
        << r.error_deg << "," << r.nees << "," << r.outcome << "," << r.active << ","
        << r.delta_error_m << "," << r.delta_error_deg << "," << r.delta_nees << ","
        << r.requested_node << "," << r.requested_keyframe_utime << "\n";
  if (auto s = writeFileAtomically(out / "registrations.csv", reg.str()); !s) return s;
  std::ostringstream nodes_csv;
  nodes_csv << "node,session,floor,true_floor,keyframe_utime,x,y,z,true_x,true_y,true_z,yaw_deg,"
               "true_yaw_deg,qw,qx,qy,qz,true_qw,true_qx,true_qy,true_qz\n";
  for (const auto& n : summary.node_rows)
    nodes_csv << n.id << "," << n.session << "," << n.floor << "," << n.true_floor << ","
              << n.keyframe_utime << "," << n.estimate.x() << "," << n.estimate.y() << ","
              << n.estimate.z() << "," << n.truth.x() << "," << n.truth.y() << "," << n.truth.z()
              << "," << n.yaw_rad * 180.0 / std::numbers::pi << ","
              << n.true_yaw_rad * 180.0 / std::numbers::pi << "," << n.rotation.w() << ","
              << n.rotation.x() << "," << n.rotation.y() << "," << n.rotation.z() << ","
              << n.true_rotation.w() << "," << n.true_rotation.x() << "," << n.true_rotation.y()
              << "," << n.true_rotation.z() << "\n";
  if (summary.node_rows.empty()) return evermap::Ok{};
  return writeFileAtomically(out / "nodes.csv", nodes_csv.str());
}

// Every output of the run into `out`, the summary printed; main's exit status.
int writeOutputs(const std::filesystem::path& out, const evermap::slam_run::SlamRunner& runner,
                 const evermap::slam_run::SlamRunSummary& summary, bool full_graph) {
  using namespace evermap;
  eval::Trajectory trajectory;
  for (const auto& [utime, pose] : summary.trajectory)
    trajectory.poses.push_back({utime * 1000, pose});
  if (Status s = eval::writeTum(trajectory, out / "trajectory.tum");
      !s && !trajectory.poses.empty())
    return fail(s.error().message, 1);
  if (Status s = writeTables(out, runner, summary); !s) return fail(s.error().message, 1);
  writeFigures(out, summary, runner.frames(), full_graph);
  const std::string text = summary.text();
  if (Status s = writeFileAtomically(out / "summary.txt", text); !s)
    return fail(s.error().message, 1);
  std::printf("%s", text.c_str());
  return 0;
}

// Localizes one session against the map in a.localize, then writes the outputs; main's exit
// status.
int runLocalize(SlamArgs& a, std::optional<evermap::sim::ImageSimOptions>& render) {
  using namespace evermap;
  if (a.logs.size() + (render ? 1 : 0) != 1)
    return fail("--localize: give one log or --render (one session)", 2);
  const std::filesystem::path map_dir(a.localize);
  a.options.store = map_dir / "map.db";
  a.options.places = map_dir / "places.db";
  std::error_code ec;
  std::filesystem::create_directories(a.out_dir, ec);
  if (ec) return fail(a.out_dir + ": cannot create (" + ec.message() + ")", 1);
  auto vocabulary = bow::loadAnyVocabulary(a.vocab_file);
  if (!vocabulary) return fail(vocabulary.error().message, 1);
  auto runner = slam_run::LocalizeRunner::create(*vocabulary, a.options);
  if (!runner) return fail(runner.error().message, 1);
  if (std::filesystem::exists(map_dir / "nodes.csv")) {
    if (Status s = (*runner)->setMapTruth(map_dir / "nodes.csv"); !s)
      return fail(s.error().message, 1);
  }
  const Status s = render ? (*runner)->renderSession(*render) : (*runner)->runLog(a.logs.front());
  if (!s) return fail(s.error().message, 1);
  const slam_run::LocalizeSummary summary = (*runner)->finish();
  if (Status w = slam_run::writeLocalization(a.out_dir, **runner, summary); !w)
    return fail(w.error().message, 1);
  std::printf("%s", summary.text().c_str());
  return 0;
}

// Maps the logs, then the rendered sessions, then writes the outputs; main's exit status.
int run(SlamArgs& a, std::optional<evermap::sim::ImageSimOptions>& render) {
  using namespace evermap;
  std::error_code ec;
  std::filesystem::create_directories(a.out_dir, ec);
  if (ec) return fail(a.out_dir + ": cannot create (" + ec.message() + ")", 1);
  const std::filesystem::path out(a.out_dir);
  a.options.store = out / "map.db";
  if (a.places) a.options.places = out / "places.db";
  const auto t0 = std::chrono::steady_clock::now();
  auto vocabulary = bow::loadAnyVocabulary(a.vocab_file);
  if (!vocabulary) return fail(vocabulary.error().message, 1);
  auto runner = slam_run::SlamRunner::create(*vocabulary, a.options);
  if (!runner) return fail(runner.error().message, 1);
  for (const std::string& log : a.logs) {
    std::fprintf(stderr, "evermap-slam-run: session %s\n", log.c_str());
    if (Status s = (*runner)->runSession(log); !s) return fail(s.error().message, 1);
  }
  for (int i = 0; render && i < a.render_sessions; ++i) {
    std::fprintf(stderr, "evermap-slam-run: rendering session %d\n", i);
    render->render.session = i;
    if (Status s = (*runner)->renderSession(*render); !s) return fail(s.error().message, 1);
  }
  auto summary = (*runner)->finish();
  if (!summary) return fail(summary.error().message, 1);
  summary->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return writeOutputs(out, **runner, *summary, a.full_graph);
}

}  // namespace

int main(int argc, char** argv) {
  SlamArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  std::optional<evermap::sim::ImageSimOptions> render;
  if (const int code = loadRender(&a, &render); code >= 0) return code;
  if (const int code = loadMapperOptions(&a); code >= 0) return code;
  if (a.options.start_session_s > 0.0 && a.localize.empty())
    return fail("--start-s is for --localize (a map is built from a session's start)", 2);
  if (a.print_config) {
    evermap::vo::PipelineOptions vo = a.options.vo;
    std::printf("%s%s%s", evermap::mapper::printMapperOptions(a.options.mapper).c_str(),
                evermap::OptionList::of(&vo, "vo.").print().c_str(),
                render ? render->toConfigText().c_str() : "");
    return 0;
  }
  // Every log whole before anything is created: a log cut mid-event is one line and no
  // output folder, not a map of part of the data.
  for (const std::string& log : a.logs) {
    if (auto events = evermap::messages::LogReader::check(log); !events)
      return fail(events.error().message, 1);
  }
  return a.localize.empty() ? run(a, render) : runLocalize(a, render);
}
