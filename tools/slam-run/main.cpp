// evermap-slam-run: the whole visual SLAM system in one process over LCM logs, one log per
// session (tools/slam-run/slam_runner.h): the map store, the live trajectory (TUM), per-frame
// CSV and a summary with the evaluation against GROUND_TRUTH where the logs have it.
// Exit status: 0 done, 1 bad input (a log, the vocabulary, the store), 2 bad command line.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "core/bow/vocabulary_io.h"
#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/eval/trajectory.h"
#include "mapper-proc/mapper_config.h"
#include "tools/slam-run/slam_runner.h"

int main(int argc, char** argv) {
  using namespace evermap;
  slam::SlamRunOptions options;
  std::string vocab_file, out_dir, config;
  std::vector<std::string> logs, sets;
  bool full_graph = false;
  CommandLine cli("evermap-slam-run",
                  "The visual SLAM system in one process: LCM logs (one per session) in, a map out.");
  cli.value("--vocab", &vocab_file, "FILE", "vocabulary (evermap-vocab-train .evoc, or DBoW2/3 .yml.gz)", true);
  cli.value("--out", &out_dir, "DIR",
            "output folder: map.db, trajectory.tum, frames.csv, registrations.csv, summary.txt (created; an existing map.db is "
            "continued as a stored map)",
            true);
  cli.flag("--full-graph", &full_graph, "a node at every step (the paper's baseline) instead of the reduced graph");
  cli.value("--config", &config, "MAPPER.conf", "mapper.* settings (docs/mapper.md)");
  cli.repeated("--set", &sets, "mapper.KEY=VALUE", "override one mapper.* setting");
  cli.value("--max-session-s", &options.max_session_s, "S", "map at most S seconds of each log (0: all)");
  cli.positional(&logs, "LOG...", "LCM logs, mapped as successive sessions");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  auto fail = [](const std::string& what, int code) {
    std::fprintf(stderr, "evermap-slam-run: %s\n", what.c_str());
    return code;
  };
  if (logs.empty()) return fail("no log given\n" + cli.usage(), 2);
  auto settings = config.empty() ? KeyValueFile::parse("", "--set") : KeyValueFile::load(config);
  if (settings) {
    if (Status s = settings->setAll(sets, "--set"); !s) settings = s.error();
  }
  if (!settings) return fail(settings.error().message, 2);
  if (Status s = mapper::readMapperOptions(*settings, &options.mapper); !s) return fail(s.error().message, 2);
  options.mapper.full_graph = full_graph;
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return fail(out_dir + ": cannot create (" + ec.message() + ")", 1);
  const std::filesystem::path out(out_dir);
  options.store = out / "map.db";

  const auto t0 = std::chrono::steady_clock::now();
  auto vocabulary = bow::loadAnyVocabulary(vocab_file);
  if (!vocabulary) return fail(vocabulary.error().message, 1);
  auto runner = slam::SlamRunner::create(*vocabulary, options);
  if (!runner) return fail(runner.error().message, 1);
  for (const std::string& log : logs) {
    std::fprintf(stderr, "evermap-slam-run: session %s\n", log.c_str());
    if (Status s = (*runner)->runSession(log); !s) return fail(s.error().message, 1);
  }
  auto summary = (*runner)->finish();
  if (!summary) return fail(summary.error().message, 1);
  summary->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  eval::Trajectory trajectory;
  for (const auto& [utime, pose] : summary->trajectory) trajectory.poses.push_back({utime * 1000, pose});
  if (Status s = eval::writeTum(trajectory, out / "trajectory.tum"); !s && !trajectory.poses.empty())
    return fail(s.error().message, 1);
  std::ostringstream csv;
  csv << "utime,session,vo_status,inliers,vo_ms,loopclose_ms,mapper_ms,nodes\n";
  for (const auto& f : (*runner)->frames())
    csv << f.utime << "," << f.session << "," << f.vo_status << "," << f.inliers << "," << f.vo_ms << ","
        << f.loopclose_ms << "," << f.mapper_ms << "," << f.nodes << "\n";
  if (Status s = writeFileAtomically(out / "frames.csv", csv.str()); !s) return fail(s.error().message, 1);
  std::ostringstream reg;
  reg << "query_utime,mode,status,node,node_keyframe_utime,inliers,score,error_m,error_deg\n";
  for (const auto& r : (*runner)->registrations())
    reg << r.query_utime << "," << r.mode << "," << r.status << "," << r.node << "," << r.node_keyframe_utime << ","
        << r.inliers << "," << r.score << "," << r.error_m << "," << r.error_deg << "\n";
  if (Status s = writeFileAtomically(out / "registrations.csv", reg.str()); !s) return fail(s.error().message, 1);
  const std::string text = summary->text();
  if (Status s = writeFileAtomically(out / "summary.txt", text); !s) return fail(s.error().message, 1);
  std::printf("%s", text.c_str());
  return 0;
}
