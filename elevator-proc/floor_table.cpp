#include "elevator-proc/floor_table.h"

#include <cmath>

#include "core/common/contract.h"

namespace evermap::elevator {

Status FloorTableOptions::validate() const {
  if (!(match_threshold_m > 0)) return makeError("floor match_threshold_m must be > 0");
  if (!(refine_weight >= 0 && refine_weight <= 1)) {
    return makeError("floor refine_weight must be in [0, 1]");
  }
  return Ok{};
}

FloorTable::FloorTable(const FloorTableOptions& options) : options_(options) {
  requireValid(options_.validate(), "evermap::elevator::FloorTable");
}

FloorAssignment FloorTable::peek(double displacement_m) const {
  FloorTable copy = *this;
  return copy.arrive(displacement_m);
}

FloorAssignment FloorTable::arrive(double displacement_m) {
  const double target = heights_[current_] + displacement_m;
  int best = -1;
  double best_distance = 0;
  for (int i = 0; i < static_cast<int>(heights_.size()); ++i) {
    const double d = std::abs(heights_[i] - target);
    if (best < 0 || d < best_distance) {
      best = i;
      best_distance = d;
    }
  }
  FloorAssignment a;
  if (best_distance <= options_.match_threshold_m) {
    heights_[best] += options_.refine_weight * (target - heights_[best]);
    a.index = best;
    a.distance_m = best_distance;
  } else {
    heights_.push_back(target);
    a.index = static_cast<int>(heights_.size()) - 1;
    a.is_new = true;
  }
  current_ = a.index;
  a.height_m = heights_[a.index];
  return a;
}

std::string FloorTable::describe() const {
  std::string s;
  char buf[64];
  for (size_t i = 0; i < heights_.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%zu: %.2f m", i ? ", " : "", i, heights_[i]);
    s += buf;
  }
  return s;
}

}  // namespace evermap::elevator
