#include "mapper-proc/floor_state.h"

#include <cmath>
#include <string>
#include <utility>

namespace evermap::mapper {

Status FloorState::check(const floor_t& msg, bool* implausible) {
  *implausible = false;
  if (!std::isfinite(msg.height_m) || !std::isfinite(msg.height_sigma_m) ||
      msg.height_sigma_m < 0 || msg.utime < last_utime_)
    return makeError("FLOOR ", msg.utime, ": not finite or out of order");
  if (const std::string why = gate_.check(msg); !why.empty()) {
    *implausible = true;
    return makeError("FLOOR ", msg.utime, ": ", why);
  }
  gate_.accept(msg);
  last_utime_ = msg.utime;
  confirmed_ = true;
  return Ok{};
}

void FloorState::rideStarts(const floor_t& msg) {
  if (floor_ >= 0) {
    height_m_ = table_.emplace(floor_, msg.height_m).first->second;
    known_ = true;  // so the ride's end moves the estimate to the new floor's height
  }
  // The cab is a place that moves: no step (no node, no registration) until the ride ends.
  in_elevator_ = true;
}

void FloorState::reach(const floor_t& msg) {
  in_elevator_ = false;
  const bool ride_end = msg.event == floor_t::EVENT_RIDE_END;
  if (ride_end) ++rides_;
  floor_ = ride_end ? floorAtHeight(msg.floor_index, msg.height_m) : msg.floor_index;
  height_m_ = msg.height_m;
  if (floor_ >= 0) height_m_ = table_.emplace(floor_, msg.height_m).first->second;
  known_ = true;
}

void FloorState::restore(std::map<int, double> floors, int guess) {
  table_ = std::move(floors);
  floor_ = guess;
  confirmed_ = false;
}

void FloorState::placeOn(int floor, std::optional<double> fallback_height_m) {
  floor_ = floor;
  confirmed_ = true;
  const auto height = table_.find(floor_);
  if (height != table_.end()) fallback_height_m = height->second;
  if (!fallback_height_m) return;
  height_m_ = *fallback_height_m;
  known_ = true;
}

int FloorState::searchFloor() {
  if (!confirmed_ && ++unconfirmed_searches_ % 2 == 1) return -1;
  return floor_;
}

int FloorState::floorAtHeight(int reported, double height_m) const {
  int best = -1;
  double best_d = floor_match_m_;
  for (const auto& [label, h] : table_) {
    if (std::abs(h - height_m) <= best_d) {
      best = label;
      best_d = std::abs(h - height_m);
    }
  }
  if (best >= 0) return best;
  if (reported < 0 || !table_.contains(reported)) return reported;
  return table_.rbegin()->first + 1;
}

}  // namespace evermap::mapper
