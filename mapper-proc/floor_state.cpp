#include "mapper-proc/floor_state.h"

#include <cmath>
#include <cstdio>
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
    height_m_ = report(floor_, msg.height_m);
    known_ = true;  // so the ride's end moves the estimate to the new floor's height
  }
  // The cab is a place that moves: no step (no node, no registration) until the ride ends.
  in_elevator_ = true;
  publish();
}

void FloorState::reach(const floor_t& msg) {
  in_elevator_ = false;
  const bool ride_end = msg.event == floor_t::EVENT_RIDE_END;
  if (ride_end) ++rides_;
  floor_ = ride_end ? floorAtHeight(msg.floor_index, msg.height_m) : msg.floor_index;
  height_m_ = msg.height_m;
  if (floor_ >= 0) height_m_ = report(floor_, msg.height_m);
  known_ = true;
  publish();
}

double FloorState::report(int floor, double height_m) {
  std::vector<Group>& groups = groups_[floor];
  ++reports_;
  Group* in = nullptr;
  for (Group& g : groups)
    if (std::abs(g.height_m - height_m) <= floor_match_m_ &&
        (!in || std::abs(g.height_m - height_m) < std::abs(in->height_m - height_m)))
      in = &g;
  if (in) {
    ++in->count;
    in->last_report = reports_;
  } else {
    groups.push_back(Group{height_m, 1, reports_});
  }
  // The group of the height in use (the first one when there is none yet), replaced by one with
  // more reports, or, while a single report gave it, by the newest contradicting one.
  const auto used = table_.find(floor);
  const Group* best = &groups.front();
  for (const Group& g : groups)
    if (used != table_.end() && g.height_m == used->second) best = &g;
  for (const Group& g : groups)
    if (g.count > best->count ||
        (g.count == best->count && best->count == 1 && g.last_report > best->last_report))
      best = &g;
  const auto [it, added] = table_.emplace(floor, best->height_m);
  if (!added && it->second != best->height_m) {
    ++heights_replaced_;
    char line[200];
    std::snprintf(line, sizeof line,
                  "floor %d: height %.3f m replaced by %.3f m (%lld reports agree with it, "
                  "%lld heights replaced)",
                  floor, it->second, best->height_m, static_cast<long long>(best->count),
                  static_cast<long long>(heights_replaced_));
    notes_.emplace_back(line);
    it->second = best->height_m;
  }
  return it->second;
}

void FloorState::nodesOn(int floor, int64_t added) {
  nodes_on_[floor] += added;
  publish();
}

void FloorState::publish() {
  published_.clear();
  for (const auto& [floor, height] : table_) {
    const auto n = nodes_on_.find(floor);
    if ((n != nodes_on_.end() && n->second > 0) || (known_ && floor == floor_))
      published_.emplace(floor, height);
  }
}

void FloorState::restore(std::map<int, double> floors, int guess) {
  table_ = std::move(floors);
  // A stored floor counts as confirmed by two reports (its nodes are the map's).
  for (const auto& [floor, height] : table_) groups_[floor] = {Group{height, 2, 0}};
  floor_ = guess;
  confirmed_ = false;
  publish();
}

void FloorState::placeOn(int floor, std::optional<double> fallback_height_m) {
  floor_ = floor;
  confirmed_ = true;
  const auto height = table_.find(floor_);
  if (height != table_.end()) fallback_height_m = height->second;
  if (fallback_height_m) {
    height_m_ = *fallback_height_m;
    known_ = true;
  }
  publish();
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
