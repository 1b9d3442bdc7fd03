#include "tools/deputy/backoff.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace evermap::deputy {

void BackoffOptions::declareOptions(OptionList& o) {
  o.add("backoff_initial_ms", &initial_delay_ms, "ms",
        "wait before the first restart after a short run")
      .nonNegative();
  o.add("backoff_factor", &factor, "", "the wait grows by this per further short run").min(1);
  o.add("backoff_max_ms", &max_delay_ms, "ms", "longest wait (at least backoff_initial_ms)")
      .nonNegative();
  o.add("stable_after_s", &stable_after_s, "s", "a run this long resets the back-off").positive();
}

Status BackoffOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (!(max_delay_ms >= initial_delay_ms)) {
    return makeError("backoff_max_ms must be >= backoff_initial_ms (", initial_delay_ms, "), got ",
                     max_delay_ms);
  }
  return Ok{};
}

std::string BackoffOptions::describe() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "backoff %g ms x%g up to %g ms, stable after %g s",
                initial_delay_ms, factor, max_delay_ms, stable_after_s);
  return buf;
}

double RespawnBackoff::onExit(double run_duration_s) {
  if (run_duration_s >= options_.stable_after_s) consecutive_short_runs_ = 0;
  ++consecutive_short_runs_;
  // factor^(n-1) overflows to inf for long crash loops; min() then caps it.
  const double grown =
      options_.initial_delay_ms * std::pow(options_.factor, consecutive_short_runs_ - 1);
  return std::min(options_.max_delay_ms, grown);
}

}  // namespace evermap::deputy
