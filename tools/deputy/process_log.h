#pragma once
// The log file of one supervised process: appended to, opened on first use, rotated when it
// grows past a size ("<file>.1" keeps the previous part). Lines of the deputy's own notes
// carry a wall-clock time stamp; the process's output is written as it came.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace evermap::deputy {

class ProcessLog {
 public:
  // `max_bytes` 0: no rotation.
  ProcessLog(std::filesystem::path file, int64_t max_bytes)
      : file_(std::move(file)), max_bytes_(max_bytes) {}
  ~ProcessLog();
  ProcessLog(const ProcessLog&) = delete;
  ProcessLog& operator=(const ProcessLog&) = delete;

  // Writes all of `bytes` (a full disk loses them: the output still goes to the network).
  void write(std::string_view bytes);
  // "[deputy 2024-05-01T12:00:00.123] text\n".
  void note(const std::string& text);
  const std::filesystem::path& file() const { return file_; }

 private:
  void open();

  std::filesystem::path file_;
  int64_t max_bytes_;
  int fd_ = -1;
  int64_t bytes_ = 0;  // size of the open file
};

}  // namespace evermap::deputy
