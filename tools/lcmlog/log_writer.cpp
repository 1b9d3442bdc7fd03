#include "tools/lcmlog/log_writer.h"

#include <system_error>
#include <unistd.h>

namespace evermap::messages {

Expected<LogWriter> LogWriter::open(const std::filesystem::path& output) {
  const std::string name = output.string();
  if (output.filename().empty()) return makeError(name, ": not a file name");
  const std::filesystem::path dir =
      output.parent_path().empty() ? std::filesystem::path(".") : output.parent_path();
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    return makeError(name, ": the folder ", dir.string(), " does not exist");
  }
  if (std::filesystem::is_directory(output, ec)) return makeError(name, ": is a folder");
  LogWriter w;
  w.output_ = output;
  // Beside the output, so the final rename stays on one file system (atomic).
  w.tmp_ = output;
  w.tmp_ += ".tmp." + std::to_string(::getpid());
  w.log_ = std::make_unique<lcm::LogFile>(w.tmp_.string(), "w");
  if (!w.log_->good()) {
    w.log_.reset();
    std::filesystem::remove(w.tmp_, ec);
    return makeError(name, ": cannot create ", w.tmp_.string());
  }
  return w;
}

LogWriter::LogWriter(LogWriter&& o) noexcept
    : output_(std::move(o.output_)),
      tmp_(std::move(o.tmp_)),
      log_(std::move(o.log_)),
      counts_(std::move(o.counts_)),
      bytes_(o.bytes_),
      event_number_(o.event_number_) {
  o.tmp_.clear();
}

LogWriter& LogWriter::operator=(LogWriter&& o) noexcept {
  if (this != &o) {
    discard();
    output_ = std::move(o.output_);
    tmp_ = std::move(o.tmp_);
    log_ = std::move(o.log_);
    counts_ = std::move(o.counts_);
    bytes_ = o.bytes_;
    event_number_ = o.event_number_;
    o.tmp_.clear();
  }
  return *this;
}

LogWriter::~LogWriter() { discard(); }

void LogWriter::discard() {
  log_.reset();
  if (!tmp_.empty()) {
    std::error_code ec;
    std::filesystem::remove(tmp_, ec);
    tmp_.clear();
  }
}

Status LogWriter::writeBytes(const std::string& channel, int64_t utime,
                             const std::vector<uint8_t>& data) {
  if (!log_) return makeError(output_.string(), ": log already closed");
  lcm::LogEvent event;
  event.eventnum = event_number_;
  event.timestamp = utime;
  event.channel = channel;
  event.datalen = static_cast<int32_t>(data.size());
  event.data = const_cast<uint8_t*>(data.data());  // LogFile only reads it
  if (log_->writeEvent(&event) != 0) {
    return makeError(tmp_.string(), ": write failed (disk full?) at event ", event_number_);
  }
  ++event_number_;
  ++counts_[channel];
  // lcm_eventlog: sync word (4) + event number (8) + timestamp (8) + channel length (4) +
  // data length (4) + channel + data.
  bytes_ += 28 + static_cast<int64_t>(channel.size()) + static_cast<int64_t>(data.size());
  return Ok{};
}

Status LogWriter::commit() {
  if (!log_) return makeError(output_.string(), ": log already closed");
  log_.reset();  // fclose: flushes
  std::error_code ec;
  const auto size = std::filesystem::file_size(tmp_, ec);
  if (ec || static_cast<int64_t>(size) != bytes_) {
    const std::string msg = tmp_.string() + ": " + std::to_string(ec ? 0 : size) +
                            " bytes on disk, " + std::to_string(bytes_) + " written (disk full?)";
    discard();
    return Error{msg};
  }
  std::filesystem::rename(tmp_, output_, ec);
  if (ec) {
    const std::string msg =
        "cannot rename " + tmp_.string() + " to " + output_.string() + ": " + ec.message();
    discard();
    return Error{msg};
  }
  tmp_.clear();
  return Ok{};
}

}  // namespace evermap::messages
