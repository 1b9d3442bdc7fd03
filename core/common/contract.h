#pragma once
// A component's options are validated where they are read (a config file, the command line):
// one handed options that do not validate is a bug in its caller, a broken contract.

#include <cstdio>
#include <cstdlib>

#include "core/common/expected.h"

namespace evermap {

// Nothing when `s` is Ok; else "who: <the error>" on stderr and abort.
inline void requireValid(const Status& s, const char* who) {
  if (s) return;
  std::fprintf(stderr, "%s: %s\n", who, s.error().message.c_str());
  std::abort();
}

}  // namespace evermap
