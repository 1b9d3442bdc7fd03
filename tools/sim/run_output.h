#pragma once
// Writing a simulated run to disk: an LCM log per session (or one for the run), ground truth
// in TUM format beside each log, and a sidecar `run.sim.txt` that makes the logs
// self-describing: it is a complete configuration (evermap-sim-measure --config run.sim.txt
// regenerates the run) followed by `meta.*` lines with the floor table, the camera mounting
// and one line per session. Every file is written under a temporary name and renamed when
// complete.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/lcmlog/log_writer.h"
#include "tools/sim/run.h"

namespace evermap::sim {

// A MessageSink that writes into an LCM log (messages::LogWriter: temporary file, renamed by
// commit()). The first write error is kept and returned by commit().
class LogWriterSink final : public MessageSink {
 public:
  explicit LogWriterSink(messages::LogWriter writer) : writer_(std::move(writer)) {}
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override;
  Status commit();

 private:
  messages::LogWriter writer_;
  std::string error_;
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
