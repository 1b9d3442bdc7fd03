#include "tools/lcmlog/log_reader.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "core/messages/envelope.h"

namespace evermap::messages {
namespace {

constexpr uint32_t kSyncWord = 0xEDA1DA01u;
constexpr int kHeaderBytes = 4 + 8 + 8 + 4 + 4;

uint64_t bigEndian(const uint8_t* p, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

LogReader::LogReader(const std::filesystem::path& file) : file_(file) {
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) {
    fail("no such log file");
    return;
  }
  if (std::filesystem::is_directory(file, ec)) {
    fail("is a folder, not an LCM log");
    return;
  }
  f_ = std::fopen(file.c_str(), "rb");
  if (!f_) {
    fail(std::string("cannot open: ") + std::strerror(errno));
    return;
  }
  struct stat st {};
  if (::fstat(::fileno(f_), &st) == 0) size_ = static_cast<int64_t>(st.st_size);
}

Expected<int64_t> LogReader::check(const std::filesystem::path& file) {
  LogReader r(file);
  r.skip_data_ = true;
  while (r.next()) {
  }
  if (r.damaged()) return Error{r.error_};
  return r.events_;
}

Expected<LogReader> LogReader::open(const std::filesystem::path& file) {
  LogReader r(file);
  if (r.damaged()) return Error{r.error_};
  return r;
}

LogReader::LogReader(LogReader&& o) noexcept
    : file_(std::move(o.file_)),
      f_(std::exchange(o.f_, nullptr)),
      offset_(o.offset_),
      size_(o.size_),
      events_(o.events_),
      done_(o.done_),
      skip_data_(o.skip_data_),
      error_(std::move(o.error_)),
      event_(std::move(o.event_)),
      buffer_(std::move(o.buffer_)) {}

LogReader& LogReader::operator=(LogReader&& o) noexcept {
  if (this != &o) {
    if (f_) std::fclose(f_);
    file_ = std::move(o.file_);
    f_ = std::exchange(o.f_, nullptr);
    offset_ = o.offset_;
    size_ = o.size_;
    events_ = o.events_;
    done_ = o.done_;
    skip_data_ = o.skip_data_;
    error_ = std::move(o.error_);
    event_ = std::move(o.event_);
    buffer_ = std::move(o.buffer_);
  }
  return *this;
}

LogReader::~LogReader() {
  if (f_) std::fclose(f_);
}

void LogReader::fail(const std::string& what) {
  done_ = true;
  if (error_.empty()) error_ = file_.string() + ": " + what;
}

Status LogReader::status() const {
  if (!error_.empty()) return Error{error_};
  return Ok{};
}

int64_t LogReader::bytesLeft() {
  // A log still being written grows: look again before calling an event truncated.
  struct stat st {};
  if (f_ && ::fstat(::fileno(f_), &st) == 0) size_ = static_cast<int64_t>(st.st_size);
  return size_ - offset_;
}

const LogReader::Event* LogReader::next() {
  if (done_ || !f_) return nullptr;
  const int64_t start = offset_;
  // Built only for a message: "byte 1234 (event 57, after 56 complete events)".
  const auto where = [&] {
    return "byte " + std::to_string(start) + " (event " + std::to_string(events_ + 1) + ", after " +
           std::to_string(events_) + " complete events)";
  };
  uint8_t header[kHeaderBytes];
  const size_t got = std::fread(header, 1, sizeof header, f_);
  if (got == 0 && std::feof(f_)) {
    done_ = true;  // the clean end: the last event ended at the end of the file
    return nullptr;
  }
  if (got < sizeof header) {
    if (std::ferror(f_)) {
      fail("read error at " + where() + ": " + std::strerror(errno));
    } else {
      fail("truncated at " + where() + ": " + std::to_string(got) + " of the " +
           std::to_string(kHeaderBytes) + " bytes of an event header");
    }
    return nullptr;
  }
  offset_ += kHeaderBytes;
  if (static_cast<uint32_t>(bigEndian(header, 4)) != kSyncWord) {
    fail("corrupt at " + where() + ": no LCM sync word (not an LCM log, or damaged)");
    return nullptr;
  }
  event_.eventnum = static_cast<int64_t>(bigEndian(header + 4, 8));
  event_.timestamp = static_cast<int64_t>(bigEndian(header + 12, 8));
  const auto channel_len = static_cast<int32_t>(bigEndian(header + 20, 4));
  const auto data_len = static_cast<int32_t>(bigEndian(header + 24, 4));
  if (channel_len < 1 || channel_len > kMaxChannelLength) {
    fail("corrupt at " + where() + ": channel length " + std::to_string(channel_len) +
         " outside [1, " + std::to_string(kMaxChannelLength) + "]");
    return nullptr;
  }
  if (data_len < 0 || data_len > kMaxMessageBytes) {
    fail("corrupt at " + where() + ": data length " + std::to_string(data_len) + " outside [0, " +
         std::to_string(kMaxMessageBytes) + "]");
    return nullptr;
  }
  const int64_t need = int64_t{channel_len} + data_len;
  if (const int64_t left = bytesLeft(); need > left) {
    fail("truncated at " + where() + ": the event claims " + std::to_string(need) +
         " bytes of channel and data, " + std::to_string(left < 0 ? 0 : left) + " are left");
    return nullptr;
  }
  if (skip_data_) {
    if (std::fseek(f_, static_cast<long>(need), SEEK_CUR) != 0) {
      fail("read error at " + where() + ": " + std::strerror(errno));
      return nullptr;
    }
    offset_ += need;
    ++events_;
    event_.data = nullptr;
    event_.datalen = data_len;
    return &event_;
  }
  event_.channel.resize(static_cast<size_t>(channel_len));
  buffer_.resize(static_cast<size_t>(data_len) + 1);  // +1: never a zero-size data pointer
  if (std::fread(event_.channel.data(), 1, event_.channel.size(), f_) != event_.channel.size() ||
      std::fread(buffer_.data(), 1, static_cast<size_t>(data_len), f_) !=
          static_cast<size_t>(data_len)) {
    fail("truncated at " + where() + " (the file shrank while it was read)");
    return nullptr;
  }
  if (event_.channel.find('\0') != std::string::npos) {
    fail("corrupt at " + where() + ": the channel name holds a NUL byte");
    return nullptr;
  }
  offset_ += need;
  event_.data = buffer_.data();
  // The sender's envelope, when one was recorded, is not part of the message.
  event_.datalen = static_cast<int32_t>(messageSize(buffer_.data(), data_len));
  ++events_;
  return &event_;
}

}  // namespace evermap::messages
