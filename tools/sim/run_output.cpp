#include "tools/sim/run_output.h"

#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <system_error>

#include "core/common/atomic_write.h"
#include "tools/eval/trajectory.h"

namespace evermap::sim {

void LogWriterSink::write(const std::string& channel, int64_t utime,
                          const std::vector<uint8_t>& data) {
  if (!error_.empty()) return;
  if (auto s = writer_.writeBytes(channel, utime, data); !s) error_ = s.error().message;
}

Status LogWriterSink::commit() {
  if (!error_.empty()) return Error{error_};
  return writer_.commit();
}

std::string sidecarText(const RunPlan& plan, const RunSummary& summary,
                        const std::vector<std::string>& log_names) {
  std::ostringstream o;
  o << "# evermap-sim-measure run description. A complete configuration: passing this file to\n"
       "# `evermap-sim-measure --config` regenerates the run. meta.* lines describe the output\n"
       "# and are ignored when read back. Floor table: index = height_m of the floor surface.\n";
  o << plan.options().toConfigText();
  char line[512];
  const Building& b = plan.building();
  o << "meta.floors = " << b.floors.size() << "\n";
  o << "meta.main_floor = " << b.main_floor << "\n";
  for (const Floor& f : b.floors) {
    std::snprintf(line, sizeof line, "meta.floor.%d.height_m = %.6f\n", f.index, f.height_m);
    o << line;
  }
  const SE3d c = plan.options().sensors.camera.bodyTCam();
  std::snprintf(line, sizeof line,
                "meta.body_T_cam = %.9f %.9f %.9f %.12f %.12f %.12f %.12f  # t, q wxyz\n",
                c.translation().x(), c.translation().y(), c.translation().z(), c.quaternion().w(),
                c.quaternion().x(), c.quaternion().y(), c.quaternion().z());
  o << line;
  for (size_t i = 0; i < summary.sessions.size(); ++i) {
    const SessionSummary& s = summary.sessions[i];
    std::string floors;
    for (int f : s.floors_visited) {
      if (!floors.empty()) floors += ',';
      floors += std::to_string(f);
    }
    const std::string& log = log_names.size() == 1 ? log_names[0] : log_names.at(i);
    std::snprintf(
        line, sizeof line,
        "meta.session.%zu = start_utime %lld end_utime %lld distance_m %.1f rides %d floors %s "
        "log %s\n",
        i, static_cast<long long>(s.start_utime), static_cast<long long>(s.end_utime), s.distance_m,
        s.rides, floors.c_str(), log.c_str());
    o << line;
  }
  for (const auto& [name, count] : summary.channels) {
    o << "meta.messages." << name << " = " << count.messages << "\n";
  }
  return o.str();
}

Expected<WrittenRun> writeRun(const RunPlan& plan, const std::filesystem::path& folder,
                              const SessionObservers& observers) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) return makeError(folder.string(), ": cannot create folder: ", ec.message());
  const bool split = plan.options().output.split_sessions;
  const bool tum = plan.options().output.tum;
  std::string error;
  WrittenRun written;
  std::unique_ptr<LogWriterSink> log;
  std::optional<eval::Trajectory> truth;
  std::string name;
  // Commits the log and writes the ground truth of the one being finished.
  auto finish = [&]() {
    if (log) {
      if (auto s = log->commit(); !s && error.empty()) error = s.error().message;
      log.reset();
    }
    if (truth) {
      if (auto s = eval::writeTum(*truth, folder / (name + ".tum")); !s && error.empty())
        error = s.error().message;
      truth.reset();
    }
  };
  SessionObservers all = observers;
  all.on_ground_truth = [&](int64_t utime, const BodyState& s) {
    if (truth) truth->poses.push_back(datasets::StampedPose{utime * 1000, s.world_T_body});
    if (observers.on_ground_truth) observers.on_ground_truth(utime, s);
  };
  NullSink discard;  // after an error: run to the end without writing
  auto sink_for = [&](int session) -> MessageSink& {
    if (!error.empty()) return discard;
    if (!log || split) {
      finish();
      char buf[32];
      std::snprintf(buf, sizeof buf, "session-%02d", session);
      name = split ? buf : "run";
      const auto path = folder / (name + ".lcmlog");
      auto opened = messages::LogWriter::open(path);
      if (!opened) {
        error = opened.error().message;
        return discard;
      }
      log = std::make_unique<LogWriterSink>(std::move(*opened));
      written.logs.push_back(path);
      if (tum) truth = eval::Trajectory{(folder / (name + ".tum")).string(), {}};
    }
    return *log;
  };
  written.summary = generateRun(plan, sink_for, all);
  finish();
  if (!error.empty()) return Error{error};
  std::vector<std::string> log_names;
  for (const auto& p : written.logs) log_names.push_back(p.filename().string());
  written.sidecar = folder / "run.sim.txt";
  if (auto s = writeFileAtomically(written.sidecar, sidecarText(plan, written.summary, log_names));
      !s) {
    return s.error();
  }
  return written;
}

}  // namespace evermap::sim
