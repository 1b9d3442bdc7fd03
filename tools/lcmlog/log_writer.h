#pragma once
// Writes an LCM log file (the format of lcm-logger / lcm::LogFile) safely: events go to a
// temporary file beside the output, which is renamed onto the output only by commit(); a
// writer destroyed without commit() removes its temporary file, so a failed or interrupted
// conversion never leaves a truncated log under the output name.
//
// Event timestamps are the messages' utime (data time, never the wall clock), so a log
// replays with the data's own timing.

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/expected.h"

namespace evermap::messages {

class LogWriter {
 public:
  // Refuses an output whose folder does not exist or is not writable.
  static Expected<LogWriter> open(const std::filesystem::path& output);

  LogWriter(LogWriter&&) noexcept;
  LogWriter& operator=(LogWriter&&) noexcept;
  ~LogWriter();

  // Appends one event (an LCM-encoded message).
  template <typename Msg>
  Status write(const std::string& channel, int64_t utime, const Msg& msg) {
    std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
    if (msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) !=
        static_cast<int>(bytes.size())) {
      return makeError(channel, ": cannot encode ", Msg::getTypeName(), " at utime ", utime);
    }
    return writeBytes(channel, utime, bytes);
  }
  Status writeBytes(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data);

  // Closes the file, checks its size against what was written and renames it onto the output.
  Status commit();

  // Messages written per channel, and the file size so far in bytes.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  int64_t bytes() const { return bytes_; }
  const std::filesystem::path& temporaryPath() const { return tmp_; }

 private:
  LogWriter() = default;
  void discard();

  std::filesystem::path output_;
  std::filesystem::path tmp_;
  std::unique_ptr<lcm::LogFile> log_;
  std::map<std::string, int64_t> counts_;
  int64_t bytes_ = 0;
  int64_t event_number_ = 0;
};

}  // namespace evermap::messages
