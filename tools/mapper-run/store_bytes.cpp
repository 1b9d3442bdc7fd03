#include "tools/mapper-run/store_bytes.h"

#include <string>
#include <system_error>

namespace evermap::mapper {

int64_t storeFileBytes(const std::filesystem::path& store) {
  int64_t bytes = 0;
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ec;
    const auto n = std::filesystem::file_size(store.string() + suffix, ec);
    if (!ec) bytes += static_cast<int64_t>(n);
  }
  return bytes;
}

}  // namespace evermap::mapper
