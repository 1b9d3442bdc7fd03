#pragma once
// The floor the robot is on, as FLOOR messages (elevator-proc) and the map tell it: the map's
// table of floor heights, the current floor and its height, whether a ride is under way, and
// whether the floor is known or only guessed (a restored map before any FLOOR message).
//
// elevator-proc numbers floors from where it started (a restarted one, a new session, calls a
// floor the map already has "new"): a ride's end is labelled from the table by its height
// (floor_match_m). A floor has one height at a time, not each ride's own estimate: that differs
// by the ride's error (0.1 m and more after a long ride), and height factors at the rides'
// estimates would hold the nodes of one floor at heights that contradict each other and the
// loop closures between them, and the solver would bend the poses (and with them x, y) to meet
// them all. Which height: the reports of a floor (a ride's start or end, a session's start) are
// grouped, each group the reports within floor_match_m of its first, and the floor's height is
// the first report of one group: the first group, until another has more reports; a height that
// a single report gave (unconfirmed) is replaced by the next report that contradicts it. On
// clean data every report of a floor falls in its first group, so the height is its first
// report, as before; a wrong first report (a forged or corrupt FLOOR; issue 47: the first
// height was kept for good) lasts until the next real report, and a wrong height that copies
// confirmed lasts only until more real reports contradict it than confirm it. A replacement
// is counted (heightsReplaced()) and noted in one line (takeNotes()).
//
// The map's floors (table()) are those a node is on, and the current one: a floor only reported
// (by traffic that made no node) is not part of the map.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

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
  // A node was made on `floor` (added > 0), or left the map (a quarantine, added < 0).
  void nodesOn(int floor, int64_t added);
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
  // The map's floors and their heights (the header's rule).
  const std::map<int, double>& table() const { return published_; }
  int64_t heightsReplaced() const { return heights_replaced_; }
  // One line for each height replaced since the last call.
  std::vector<std::string> takeNotes() { return std::move(notes_); }

 private:
  // The map's label for the floor a ride ended on at height_m (FLOOR's reported label): the
  // floor of the table at that height, else the reported label if the table has no floor by
  // it, else a new label.
  int floorAtHeight(int reported, double height_m) const;
  // A report of `floor` at height_m: the floor's height after it.
  double report(int floor, double height_m);
  void publish();
  struct Group {
    double height_m;      // its first report's
    int64_t count;        // reports in it
    int64_t last_report;  // when it was last reported (reports_ at the time)
  };

  double floor_match_m_;
  FloorGate gate_;
  int64_t last_utime_ = -1;
  int floor_ = 0;
  double height_m_ = 0.0;
  std::map<int, double> table_;      // every floor reported, at its height
  std::map<int, double> published_;  // the map's floors (table())
  std::map<int, std::vector<Group>> groups_;
  std::map<int, int64_t> nodes_on_;
  int64_t reports_ = 0;
  int64_t heights_replaced_ = 0;
  std::vector<std::string> notes_;
  bool known_ = false;
  bool confirmed_ = true;  // false: a restored map's guess
  int64_t unconfirmed_searches_ = 0;
  bool in_elevator_ = false;  // between a ride's start and end
  int64_t rides_ = 0;
};

}  // namespace evermap::mapper
