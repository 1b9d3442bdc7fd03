#include "tools/deputy/process_log.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <ctime>

namespace evermap::deputy {
namespace {

std::string wallTimeText() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  tm local{};
  localtime_r(&ts.tv_sec, &local);
  char buf[64];
  const size_t n = std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &local);
  std::snprintf(buf + n, sizeof buf - n, ".%03ld", ts.tv_nsec / 1000000);
  return buf;
}

}  // namespace

ProcessLog::~ProcessLog() {
  if (fd_ >= 0) ::close(fd_);
}

void ProcessLog::open() {
  fd_ = ::open(file_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  struct stat st {};
  bytes_ = (fd_ >= 0 && ::fstat(fd_, &st) == 0) ? st.st_size : 0;
}

void ProcessLog::write(std::string_view bytes) {
  if (fd_ >= 0 && max_bytes_ > 0 && bytes_ >= max_bytes_) {
    ::close(fd_);
    fd_ = -1;
    std::error_code ec;
    std::filesystem::rename(file_, file_.string() + ".1", ec);
  }
  if (fd_ < 0) open();
  while (fd_ >= 0 && !bytes.empty()) {
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    bytes_ += n;
    bytes.remove_prefix(static_cast<size_t>(n));
  }
}

void ProcessLog::note(const std::string& text) {
  write("[deputy " + wallTimeText() + "] " + text + "\n");
}

}  // namespace evermap::deputy
