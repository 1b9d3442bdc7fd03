#include "core/sim/run_output.h"

#include <cstdio>
#include <sstream>
#include <system_error>

namespace evermap::sim {
namespace {

std::filesystem::path tempNameFor(const std::filesystem::path& path) {
  return path.parent_path() / (path.filename().string() + ".partial");
}

Status renameInto(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::error_code ec;
  std::filesystem::rename(from, to, ec);
  if (ec) return makeError(to.string(), ": cannot rename from ", from.filename().string(), ": ", ec.message());
  return Ok{};
}

Status writeTextFile(const std::filesystem::path& path, const std::string& text) {
  const auto temp = tempNameFor(path);
  {
    std::ofstream out(temp);
    if (!out) return makeError(temp.string(), ": cannot create");
    out << text;
    if (!out.flush()) return makeError(temp.string(), ": write failed");
  }
  return renameInto(temp, path);
}

}  // namespace

Expected<std::unique_ptr<LogFileSink>> LogFileSink::open(const std::filesystem::path& path) {
  std::unique_ptr<LogFileSink> sink(new LogFileSink());
  sink->path_ = path;
  sink->temp_ = tempNameFor(path);
  sink->log_ = std::make_unique<lcm::LogFile>(sink->temp_.string(), "w");
  if (!sink->log_->good()) return makeError(sink->temp_.string(), ": cannot create LCM log");
  return sink;
}

LogFileSink::~LogFileSink() {
  if (log_) {
    log_.reset();
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void LogFileSink::write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) {
  if (!log_ || !error_.empty()) return;
  lcm::LogEvent ev;
  ev.eventnum = 0;  // assigned by LCM
  ev.timestamp = utime;
  ev.channel = channel;
  ev.datalen = static_cast<int32_t>(data.size());
  ev.data = const_cast<uint8_t*>(data.data());
  if (log_->writeEvent(&ev) != 0) error_ = temp_.string() + ": write failed (disk full?)";
}

Status LogFileSink::close() {
  if (!log_) return makeError(path_.string(), ": closed twice");
  log_.reset();  // flushes and closes
  if (!error_.empty()) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
    return Error{error_};
  }
  return renameInto(temp_, path_);
}

Expected<std::unique_ptr<TumWriter>> TumWriter::open(const std::filesystem::path& path) {
  std::unique_ptr<TumWriter> w(new TumWriter());
  w->path_ = path;
  w->temp_ = tempNameFor(path);
  w->out_.open(w->temp_);
  if (!w->out_) return makeError(w->temp_.string(), ": cannot create");
  w->out_ << "# ground truth world_T_body: time[s] tx ty tz qx qy qz qw\n";
  return w;
}

TumWriter::~TumWriter() {
  if (!closed_) {
    out_.close();
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void TumWriter::add(int64_t utime, const SE3d& pose) {
  const Vec3& t = pose.translation();
  const Eigen::Quaterniond& q = pose.quaternion();
  char line[256];
  std::snprintf(line, sizeof line, "%lld.%06lld %.9f %.9f %.9f %.12f %.12f %.12f %.12f\n",
                static_cast<long long>(utime / 1000000), static_cast<long long>(utime % 1000000), t.x(),
                t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  out_ << line;
}

Status TumWriter::close() {
  closed_ = true;
  out_.close();
  if (!out_) return makeError(temp_.string(), ": write failed");
  return renameInto(temp_, path_);
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
  std::snprintf(line, sizeof line, "meta.body_T_cam = %.9f %.9f %.9f %.12f %.12f %.12f %.12f  # t, q wxyz\n",
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
    std::snprintf(line, sizeof line,
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
  std::vector<std::string> names;
  for (int i = 0; i < (split ? plan.sessions() : 1); ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "session-%02d", i);
    names.push_back(split ? name : "run");
  }
  std::unique_ptr<LogFileSink> log;
  std::unique_ptr<TumWriter> tum_writer;
  std::string error;
  WrittenRun written;
  auto finish = [&]() {
    if (log) {
      if (auto s = log->close(); !s && error.empty()) error = s.error().message;
      log.reset();
    }
    if (tum_writer) {
      if (auto s = tum_writer->close(); !s && error.empty()) error = s.error().message;
      tum_writer.reset();
    }
  };
  SessionObservers all = observers;
  all.on_ground_truth = [&](int64_t utime, const BodyState& s) {
    if (tum_writer) tum_writer->add(utime, s.world_T_body);
    if (observers.on_ground_truth) observers.on_ground_truth(utime, s);
  };
  NullSink discard;  // after an error: run to the end without writing
  auto sink_for = [&](int session) -> MessageSink& {
    if (!error.empty()) return discard;
    if (!log || split) {
      finish();
      const std::string& name = names[split ? session : 0];
      auto opened = LogFileSink::open(folder / (name + ".lcmlog"));
      if (!opened) {
        error = opened.error().message;
        return discard;
      }
      log = std::move(*opened);
      written.logs.push_back(folder / (name + ".lcmlog"));
      if (tum) {
        auto t = TumWriter::open(folder / (name + ".tum"));
        if (!t) {
          error = t.error().message;
          return discard;
        }
        tum_writer = std::move(*t);
      }
    }
    return *log;
  };
  written.summary = generateRun(plan, sink_for, all);
  finish();
  if (!error.empty()) return Error{error};
  std::vector<std::string> log_names;
  for (const auto& p : written.logs) log_names.push_back(p.filename().string());
  written.sidecar = folder / "run.sim.txt";
  if (auto s = writeTextFile(written.sidecar, sidecarText(plan, written.summary, log_names)); !s) {
    return s.error();
  }
  return written;
}

}  // namespace evermap::sim
