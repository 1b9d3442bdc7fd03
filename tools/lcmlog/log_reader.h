#pragma once
// Reads an LCM log file (lcm-logger's format, lcm_eventlog.c) and says when it is damaged.
//
// lcm::LogFile of LCM 1.3.1 cannot be used on untrusted logs: it ends a log cut mid-event
// as if it were complete (a tool then reports a result from part of the data, exit 0), it
// skips garbage until the next sync word without telling, ignores short reads of the event
// header, asserts on a channel length of 1000 or more and allocates whatever length an event
// claims. LogReader checks every event against the bytes present before it allocates, and
// stops at the first damage with one line that names the file, the byte offset, the event
// and how many events were read before it:
//
//   LogReader log(file);                        // or LogReader::open(file) for an Expected
//   while (const LogReader::Event* e = log.next()) { ... e->channel, e->data, e->datalen ... }
//   if (Status s = log.status(); !s) return s.error();   // truncated or corrupt
//
// An event is: sync word 0xEDA1DA01, event number (int64), timestamp (int64, µs), channel
// length (int32), data length (int32), channel bytes, data bytes; all big-endian.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap::messages {

class LogReader {
 public:
  struct Event {
    int64_t eventnum = 0;
    int64_t timestamp = 0;  // µs, as lcm-logger (or LogWriter: the message's utime) wrote it
    std::string channel;
    // The LCM message, valid until the next call of next(); an envelope recorded behind it
    // (core/messages/envelope.h: a live evermap process's) is left out of datalen.
    const uint8_t* data = nullptr;
    int32_t datalen = 0;
  };
  // LCM's own limits: lcm_eventlog.c asserts channel lengths below 1000; LCM_MAX_MESSAGE_SIZE.
  static constexpr int32_t kMaxChannelLength = 999;
  static constexpr int32_t kMaxMessageBytes = 1 << 28;

  // Opens `file`; an unreadable or missing file is an error here (open()), or a failed
  // status() with no events (the constructor).
  static Expected<LogReader> open(const std::filesystem::path& file);
  explicit LogReader(const std::filesystem::path& file);
  LogReader(LogReader&&) noexcept;
  LogReader& operator=(LogReader&&) noexcept;
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;
  ~LogReader();

  // Reads the whole log's event headers (the data is skipped, not read: a scan of a 1 GB
  // stereo log takes milliseconds) and returns the number of events, or the error next()
  // would end with. Tools check their input logs with it before they create any output.
  static Expected<int64_t> check(const std::filesystem::path& file);

  // The next event, or nullptr at the end of the log or at the first damage (then status()
  // says what). After nullptr, next() keeps returning nullptr.
  const Event* next();

  // Ok while no damage was found (and after a clean end); else the one-line error.
  Status status() const;
  bool damaged() const { return !error_.empty(); }
  // Events returned so far.
  int64_t events() const { return events_; }
  const std::filesystem::path& file() const { return file_; }

 private:
  void fail(const std::string& what);
  int64_t bytesLeft();

  std::filesystem::path file_;
  std::FILE* f_ = nullptr;
  int64_t offset_ = 0;  // of the next unread byte
  int64_t size_ = 0;    // the file's size, re-read when an event seems to pass the end
  int64_t events_ = 0;
  bool done_ = false;
  bool skip_data_ = false;  // check(): seek over channel and data
  std::string error_;
  Event event_;
  std::vector<uint8_t> buffer_;
};

}  // namespace evermap::messages
