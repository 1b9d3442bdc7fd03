#pragma once
// Writing a whole file so that a reader never sees half of it: the bytes go to a temporary
// file in the same folder (same file system, so the rename is atomic), which is flushed and
// then renamed over the target. A crash leaves either the old file or the new one.

#include <filesystem>
#include <string_view>

#include "core/common/expected.h"

namespace evermap {

// Writes `bytes` to `file` through "<folder>/.<name>.tmp<pid>" and a rename. An error names
// the file and what failed (folder missing, disk full, permission).
Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes);

}  // namespace evermap
