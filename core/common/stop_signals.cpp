#include "core/common/stop_signals.h"

#include <ctime>

namespace evermap {

StopSignals::StopSignals() {
  sigemptyset(&set_);
  sigaddset(&set_, SIGINT);
  sigaddset(&set_, SIGTERM);
  sigprocmask(SIG_BLOCK, &set_, nullptr);
}

bool StopSignals::requested() {
  const timespec no_wait{0, 0};
  if (!seen_ && sigtimedwait(&set_, nullptr, &no_wait) >= 0) seen_ = true;
  return seen_;
}

}  // namespace evermap
