#include "tools/deputy/backoff.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace evermap::deputy {

Status BackoffOptions::validate() const {
  if (!(initial_delay_ms >= 0.0) || !std::isfinite(initial_delay_ms)) {
    return makeError("backoff initial_delay_ms must be finite and >= 0, got ", initial_delay_ms);
  }
  if (!(factor >= 1.0) || !std::isfinite(factor)) {
    return makeError("backoff factor must be finite and >= 1, got ", factor);
  }
  if (!(max_delay_ms >= initial_delay_ms) || !std::isfinite(max_delay_ms)) {
    return makeError("backoff max_delay_ms must be finite and >= initial_delay_ms, got ",
                     max_delay_ms);
  }
  if (!(stable_after_s > 0.0) || !std::isfinite(stable_after_s)) {
    return makeError("backoff stable_after_s must be finite and > 0, got ", stable_after_s);
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
