#include "core/common/atomic_write.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

namespace evermap {

Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes) {
  namespace fs = std::filesystem;
  if (file.filename().empty()) return makeError(file.string(), ": not a file name");
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  std::string tmp_name = ".";
  tmp_name += file.filename().string();
  tmp_name += ".tmp";
  tmp_name += std::to_string(::getpid());
  const fs::path tmp = folder / tmp_name;
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f)
    return makeError(file.string(), ": cannot create ", tmp.string(), ": ", std::strerror(errno));
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  // fsync so that the rename never exposes a file whose data is not on disk yet.
  const bool flushed = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const int saved_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!written || !flushed || !closed) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return makeError(file.string(), ": write failed: ", std::strerror(saved_errno));
  }
  std::error_code ec;
  fs::rename(tmp, file, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(tmp, ec);
    return makeError(file.string(), ": cannot rename the temporary file: ", why);
  }
  return Ok{};
}

}  // namespace evermap
