#pragma once
// Writing a simulated run to disk: an LCM log per session (or one for the run), ground truth
// in TUM format beside each log, and a sidecar `run.sim.txt` that makes the logs
// self-describing: it is a complete configuration (evermap-sim-measure --config run.sim.txt
// regenerates the run) followed by `meta.*` lines with the floor table, the camera mounting
// and one line per session. Every file is written under a temporary name and renamed when
// complete.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/expected.h"
#include "core/sim/run.h"

namespace evermap::sim {

class LogFileSink final : public MessageSink {
 public:
  static Expected<std::unique_ptr<LogFileSink>> open(const std::filesystem::path& path);
  ~LogFileSink() override;  // an unclosed log is removed
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override;
  // Closes the log and renames it into place; the first write error, if any.
  Status close();

 private:
  LogFileSink() = default;
  std::filesystem::path path_;
  std::filesystem::path temp_;
  std::unique_ptr<lcm::LogFile> log_;
  std::string error_;
};

// Ground truth as TUM text: `time tx ty tz qx qy qz qw`, time in seconds.
class TumWriter {
 public:
  static Expected<std::unique_ptr<TumWriter>> open(const std::filesystem::path& path);
  ~TumWriter();
  void add(int64_t utime, const SE3d& pose);
  Status close();

 private:
  TumWriter() = default;
  std::filesystem::path path_;
  std::filesystem::path temp_;
  std::ofstream out_;
  bool closed_ = false;
};

struct WrittenRun {
  RunSummary summary;
  std::vector<std::filesystem::path> logs;
  std::filesystem::path sidecar;
};

// The sidecar text for a run (see above).
std::string sidecarText(const RunPlan& plan, const RunSummary& summary,
                        const std::vector<std::string>& log_names);

// Generates the run into `folder` (created if missing). `observers` see every session.
Expected<WrittenRun> writeRun(const RunPlan& plan, const std::filesystem::path& folder,
                              const SessionObservers& observers = {});

}  // namespace evermap::sim
