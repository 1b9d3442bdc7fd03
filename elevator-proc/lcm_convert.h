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
  switch (e.kind) {
    case FloorEvent::Kind::kRideStart:
      m.event = floor_t::EVENT_RIDE_START;
      break;
    case FloorEvent::Kind::kRideEnd:
      m.event = floor_t::EVENT_RIDE_END;
      break;
    case FloorEvent::Kind::kVerticalMotion:
      m.event = floor_t::EVENT_VERTICAL_MOTION;
      break;
    case FloorEvent::Kind::kVerticalStill:
      m.event = floor_t::EVENT_VERTICAL_STILL;
      break;
  }
  m.new_floor = e.new_floor ? 1 : 0;
  return m;
}

// For log lines: what a FLOOR message's event says, one word ("start" and "end" of a ride,
// "motion" and "still" of the vertical watch).
inline const char* floorEventName(int8_t event) {
  switch (event) {
    case floor_t::EVENT_NONE:
      return "none";
    case floor_t::EVENT_RIDE_START:
      return "start";
    case floor_t::EVENT_RIDE_END:
      return "end";
    case floor_t::EVENT_VERTICAL_MOTION:
      return "motion";
    case floor_t::EVENT_VERTICAL_STILL:
      return "still";
    default:
      return "unknown";
  }
}

}  // namespace evermap::elevator
