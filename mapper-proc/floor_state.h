#pragma once
// The floor the robot is on, as FLOOR messages (elevator-proc) and the map tell it: the map's
// table of floor heights, the current floor and its height, whether a ride is under way, and
// whether the floor is known or only guessed (a restored map before any FLOOR message).
//
// elevator-proc numbers floors from where it started (a restarted one, a new session, calls a
// floor the map already has "new"): a ride's end is labelled from the table by its height
// (floor_match_m). A floor has one height: the first one reported for it, as restore() reads
// it back. Each ride's own height estimate differs from it by that ride's error (0.1 m and more
// after a long ride); height factors at the ride's estimate would hold the nodes of one floor
// at heights that contradict each other and the loop closures between them, and the solver
// would bend the poses (and with them x, y) to meet them all.

#include <cstdint>
#include <map>
#include <optional>

#include <evermap/floor_t.hpp>

#include "core/common/expected.h"
#include "mapper-proc/floor_gate.h"

namespace evermap::mapper {

class FloorState {
 public:
  FloorState(double floor_match_m, const FloorGateOptions& gate)
      : floor_match_m_(floor_match_m), gate_(gate) {}

  // An error for a FLOOR message to drop: not finite, out of order, or implausible after the
  // messages taken so far (floor_gate.h; *implausible then). Otherwise the message is taken
  // as the gate's reference, and the floor is no longer a guess.
  Status check(const floor_t& msg, bool* implausible);
  // A ride starts: the floor left enters the table at the height the ride starts from
  // (elevator-proc announces no floor before the first ride). No steps until it ends.
  void rideStarts(const floor_t& msg);
  // A floor reached (a ride's end, a session's start): its label and its height.
  void reach(const floor_t& msg);
  // restore(): the stored table, and the floor guessed (the newest node's) until a FLOOR
  // message or a placement on the map confirms it.
  void restore(std::map<int, double> floors, int guess);
  // The robot placed on `floor` (a relocalisation, a warm restart): confirmed; its height from
  // the table, else fallback_height_m if given.
  void placeOn(int floor, std::optional<double> fallback_height_m);
  // The floor a global search covers: the current one, or every floor (-1) on every other
  // search while the floor is a guess (the first included).
  int searchFloor();

  int floor() const { return floor_; }
  double heightM() const { return height_m_; }
  // A floor height is known (a FLOOR message or a placement gave one).
  bool known() const { return known_; }
  bool confirmed() const { return confirmed_; }
  bool inElevator() const { return in_elevator_; }
  int64_t rides() const { return rides_; }  // ride ends seen
  const std::map<int, double>& table() const { return table_; }

 private:
  // The map's label for the floor a ride ended on at height_m (FLOOR's reported label): the
  // floor of the table at that height, else the reported label if the table has no floor by
  // it, else a new label.
  int floorAtHeight(int reported, double height_m) const;

  double floor_match_m_;
  FloorGate gate_;
  int64_t last_utime_ = -1;
  int floor_ = 0;
  double height_m_ = 0.0;
  std::map<int, double> table_;
  bool known_ = false;
  bool confirmed_ = true;  // false: a restored map's guess
  int64_t unconfirmed_searches_ = 0;
  bool in_elevator_ = false;  // between a ride's start and end
  int64_t rides_ = 0;
};

}  // namespace evermap::mapper
