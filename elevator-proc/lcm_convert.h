#pragma once
// FLOOR messages from the tracker's events.

#include <evermap/floor_t.hpp>

#include "elevator-proc/elevator_tracker.h"

namespace evermap::elevator {

inline floor_t toLcm(const FloorEvent& e) {
  floor_t m;
  m.utime = e.utime;
  m.floor_index = e.floor_index;
  m.height_m = e.height_m;
  m.height_sigma_m = e.height_sigma_m;
  m.in_elevator = e.in_elevator ? 1 : 0;
  m.event =
      e.kind == FloorEvent::Kind::kRideStart ? floor_t::EVENT_RIDE_START : floor_t::EVENT_RIDE_END;
  m.new_floor = e.new_floor ? 1 : 0;
  return m;
}

}  // namespace evermap::elevator
