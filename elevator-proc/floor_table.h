#pragma once
// The table of floor heights (paper section IV-F): "Each time a transition is detected the
// table is searched for the closest floor. If the distance to that floor is within a given
// threshold it is accepted as the current floor, otherwise a new floor is added."
//
// Heights are relative to the floor the session started on (floor 0 at 0 m). Indices are
// stable: a floor keeps the index it was given when first reached (the order of discovery,
// not of height), so other processes can key data on it.

#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap::elevator {

struct FloorTableOptions {
  // A ride ending within this of a known floor's height arrives at that floor.
  double match_threshold_m = 1.5;
  // When matched, the floor's height moves towards the arrival by this weight (0: the
  // first visit fixes it, as the paper; > 0: averages arrivals).
  double refine_weight = 0.0;
  Status validate() const;
};

struct FloorAssignment {
  int index = 0;
  double height_m = 0;
  bool is_new = false;
  double distance_m = 0;  // |arrival - table height| (0 for a new floor)
};

class FloorTable {
 public:
  explicit FloorTable(const FloorTableOptions& options = {});

  // The floor a ride that moved displacement_m from the current floor arrives at; it
  // becomes the current floor.
  FloorAssignment arrive(double displacement_m);
  // What arrive() would return, without changing the table.
  FloorAssignment peek(double displacement_m) const;

  int current() const { return current_; }
  double currentHeight() const { return heights_[current_]; }
  const std::vector<double>& heights() const { return heights_; }
  std::string describe() const;  // "0: 0.00 m, 1: 3.52 m, ..."

 private:
  FloorTableOptions options_;
  std::vector<double> heights_{0.0};
  int current_ = 0;
};

}  // namespace evermap::elevator
