#pragma once
// Checks that messages received over LCM are exactly the messages of a log file: per channel,
// the same number, in the same order, byte for byte, and each decodes as an evermap type.
// Used by the replay integration test and by `evermap-lcm-check`.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap::messages {

struct ChannelReport {
  std::string type;      // evermap type name, or "?" when the fingerprint is unknown
  int64_t expected = 0;  // messages in the log
  int64_t received = 0;
  int64_t intact = 0;       // received, in order, byte-identical to the log
  int64_t corrupt = 0;      // received but matching no logged message still due
  int64_t undecodable = 0;  // received but not a cleanly decodable evermap message
  int64_t bytes = 0;        // total bytes received
};

struct CompareSummary {
  std::map<std::string, ChannelReport> channels;
  int64_t expected = 0;
  int64_t received = 0;
  int64_t intact = 0;
  bool complete() const { return expected == intact && received == expected; }
  // One line per channel and a total, for printing.
  std::string table() const;
};

class LogComparator {
 public:
  // Reads every event of an LCM log; an unreadable or truncated log is an error naming it.
  static Expected<LogComparator> fromLog(const std::filesystem::path& log);

  // Records one received message.
  void onMessage(const std::string& channel, const void* data, size_t size);
  // True once every logged message has been received (intact or not).
  bool allReceived() const { return received_total_ >= expected_total_; }
  int64_t expectedTotal() const { return expected_total_; }
  CompareSummary summary() const;

 private:
  std::map<std::string, std::vector<std::vector<uint8_t>>> expected_;
  std::map<std::string, ChannelReport> reports_;
  std::map<std::string, int64_t> cursors_;  // next unmatched logged message per channel
  int64_t expected_total_ = 0;
  int64_t received_total_ = 0;
};

}  // namespace evermap::messages
