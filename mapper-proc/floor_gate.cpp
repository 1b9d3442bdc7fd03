#include "mapper-proc/floor_gate.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace evermap::mapper {

std::string FloorGate::check(const floor_t& msg) const {
  std::ostringstream why;
  if (!(std::abs(msg.height_m) <= o_.max_height_m)) {
    why << "height " << msg.height_m << " m is beyond floor_gate.max_height_m " << o_.max_height_m;
    return why.str();
  }
  if (!last_ || msg.event == floor_t::EVENT_NONE) return {};
  const double span_s = std::max(1e-3, 1e-6 * static_cast<double>(msg.utime - last_->utime));
  const double change_m = std::abs(msg.height_m - last_->height_m);
  if (change_m > o_.max_vertical_speed_m_s * span_s) {
    why << "height " << msg.height_m << " m is " << change_m << " m from the last FLOOR's "
        << last_->height_m << " m in " << span_s
        << " s, faster than floor_gate.max_vertical_speed_m_s " << o_.max_vertical_speed_m_s;
  }
  return why.str();
}

}  // namespace evermap::mapper
