#pragma once
// The size of a map store on disk.

#include <cstdint>
#include <filesystem>

namespace evermap::mapper {

// The bytes of the store's database file and its write-ahead log (FILE-wal); a missing file
// counts 0.
int64_t storeFileBytes(const std::filesystem::path& store);

}  // namespace evermap::mapper
