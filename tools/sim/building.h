#pragma once
// A multi-floor building for the measurement-level simulator (DESIGN.md section 8).
//
// Each floor is a ladder of corridors: `long_corridors` parallel corridors along x (the first
// at y = 0, the others at y = -k * long_corridor_spacing_m) joined by cross corridors along y,
// with rooms hanging off the long corridors through doors. The walkable space is a graph of
// places (corridor junctions, doors, room centres, the elevator lobby and cab) joined by
// straight passages; the robot drives along passages and turns in place at places.
// The elevator shaft is at the same (x, y) on every floor: its cab is a box on the +y side of
// the corridor y = 0 at x = 0, reached from the lobby place at the origin.
//
// Floors are indexed from 0 (the lowest); floor i is at height_m above floor 0. The floor
// table (index, height) is what elevator-proc would hold; the simulator writes it beside
// every log.

#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se2.h"
#include "tools/sim/random.h"

namespace evermap::sim {

using core::Vec2;

struct Box {
  Vec2 min = Vec2::Zero();
  Vec2 max = Vec2::Zero();
  bool contains(const Vec2& p) const {
    return p.x() >= min.x() && p.x() <= max.x() && p.y() >= min.y() && p.y() <= max.y();
  }
};

enum class PlaceKind { kJunction, kDoor, kRoom, kLobby, kCab };
const char* placeKindName(PlaceKind kind);

struct Place {
  Vec2 xy = Vec2::Zero();
  PlaceKind kind = PlaceKind::kJunction;
  int room = -1;            // kDoor, kRoom: index into Floor::rooms
  bool blank_wall = false;  // turning here faces a featureless wall (VO fails during the turn)
};

struct Passage {
  int to = 0;
  double length_m = 0.0;
};

struct Room {
  Box box;
  bool dark = false;  // lights off: VO fails while the camera is inside
  int door = -1;      // place index
  int centre = -1;    // place index
};

struct Floor {
  int index = 0;
  double height_m = 0.0;  // of the floor surface above floor 0
  Box footprint;
  std::vector<Place> places;
  std::vector<std::vector<Passage>> passages;  // adjacency, per place
  std::vector<Room> rooms;
  Box cab;             // elevator cab interior
  int lobby = -1;      // place in front of the elevator door
  int cab_place = -1;  // place inside the cab

  // The room whose box contains p, or -1.
  int roomAt(const Vec2& p) const;
  // Places from `from` to `to` along the shortest walkable path (Dijkstra), both included.
  std::vector<int> shortestPath(int from, int to) const;
  // Walking distance from `from` to every place (infinity when unreachable).
  std::vector<double> distancesFrom(int from) const;
  double passageLength() const;  // total length of all passages, metres
};

struct BuildingOptions {
  int floors = 10;
  int main_floor = 2;            // the floor patrolled most (the paper's experiments: floor 3)
  double storey_height_m = 4.5;  // nominal floor-to-floor height
  double storey_jitter_m = 0.4;  // each storey height is nominal ± this (uniform)
  double corridor_half_width_m = 1.25;
  double cross_corridor_spacing_m = 15.0;
  double long_corridor_spacing_m = 16.0;
  int main_cross_corridors = 7;  // main floor: 7 cross corridors -> 90 m long
  int main_long_corridors = 2;
  int min_cross_corridors = 3;  // other floors: drawn in [min, max]
  int max_cross_corridors = 7;
  int max_long_corridors = 2;  // other floors: drawn in [1, max]
  double room_width_m = 5.0;
  double room_depth_m = 6.0;
  double room_probability = 0.6;  // per room slot along a corridor side
  double dark_room_fraction = 0.15;
  double blank_wall_fraction = 0.2;  // of junctions
  double cab_width_m = 2.0;
  double cab_depth_m = 2.0;

  Status validate() const;
};

struct Building {
  std::vector<Floor> floors;
  int main_floor = 0;
  int home_place = -1;  // on the main floor: where every session starts and ends

  // Floor index whose height is nearest to z.
  int nearestFloor(double z) const;
};

// Generates the building; `rng` decides layouts, rooms, dark rooms and blank walls.
Building generateBuilding(const BuildingOptions& options, Random& rng);

// A single flat floor with no places (for runs along a recorded trajectory).
Building flatBuilding();

}  // namespace evermap::sim
