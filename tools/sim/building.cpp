#include "tools/sim/building.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

namespace evermap::sim {
namespace {

// Builds one floor; see the layout described in building.h.
class FloorBuilder {
 public:
  FloorBuilder(const BuildingOptions& o, Random& rng) : o_(o), rng_(rng) {}

  Floor build(int index, double height_m, int n_cross, int n_long, double x_min) {
    floor_ = Floor{};
    floor_.index = index;
    floor_.height_m = height_m;
    const double hw = o_.corridor_half_width_m;
    const double s = o_.cross_corridor_spacing_m;
    const double length = (n_cross - 1) * s;
    const double y_low = -(n_long - 1) * o_.long_corridor_spacing_m;
    floor_.footprint = Box{Vec2(x_min - hw, y_low - hw - o_.room_depth_m),
                           Vec2(x_min + length + hw, hw + o_.room_depth_m)};
    stations_.assign(n_long, {});
    std::vector<std::vector<int>> junction(n_cross, std::vector<int>(n_long));
    for (int c = 0; c < n_long; ++c) {
      for (int k = 0; k < n_cross; ++k) {
        junction[k][c] = station(c, x_min + k * s, PlaceKind::kJunction);
        floor_.places[junction[k][c]].blank_wall = rng_.bernoulli(o_.blank_wall_fraction);
      }
    }
    addElevator();
    for (int c = 0; c < n_long; ++c) {
      for (int k = 0; k + 1 < n_cross; ++k) {
        for (int side : {+1, -1}) addRooms(c, x_min + k * s, side);
      }
    }
    // Passages along each long corridor, between consecutive stations.
    for (int c = 0; c < n_long; ++c) {
      auto& st = stations_[c];
      std::sort(st.begin(), st.end());
      for (size_t i = 0; i + 1 < st.size(); ++i) connect(st[i].second, st[i + 1].second);
    }
    for (int k = 0; k < n_cross; ++k) {
      for (int c = 0; c + 1 < n_long; ++c) connect(junction[k][c], junction[k][c + 1]);
    }
    return std::move(floor_);
  }

 private:
  int addPlace(const Vec2& xy, PlaceKind kind) {
    floor_.places.push_back(Place{xy, kind, -1, false});
    floor_.passages.emplace_back();
    return static_cast<int>(floor_.places.size()) - 1;
  }

  // The place on long corridor c at x, created if none is within 1 cm.
  int station(int c, double x, PlaceKind kind) {
    for (const auto& [sx, id] : stations_[c]) {
      if (std::abs(sx - x) < 0.01) return id;
    }
    const int id = addPlace(Vec2(x, -c * o_.long_corridor_spacing_m), kind);
    stations_[c].emplace_back(x, id);
    return id;
  }

  void connect(int a, int b) {
    const double d = (floor_.places[a].xy - floor_.places[b].xy).norm();
    floor_.passages[a].push_back(Passage{b, d});
    floor_.passages[b].push_back(Passage{a, d});
  }

  void addElevator() {
    const double hw = o_.corridor_half_width_m;
    floor_.lobby = station(0, 0.0, PlaceKind::kLobby);
    floor_.places[floor_.lobby].kind = PlaceKind::kLobby;
    floor_.cab =
        Box{Vec2(-0.5 * o_.cab_width_m, hw), Vec2(0.5 * o_.cab_width_m, hw + o_.cab_depth_m)};
    floor_.cab_place = addPlace(Vec2(0.0, hw + 0.5 * o_.cab_depth_m), PlaceKind::kCab);
    connect(floor_.lobby, floor_.cab_place);
  }

  // Rooms on one side of long corridor c between the cross corridors at x0 and x0 + spacing.
  void addRooms(int c, double x0, int side) {
    const double hw = o_.corridor_half_width_m;
    const double rw = o_.room_width_m;
    const double usable = o_.cross_corridor_spacing_m - 2.0 * hw;
    const int slots = static_cast<int>(std::floor(usable / rw));
    const double first = x0 + 0.5 * o_.cross_corridor_spacing_m - 0.5 * slots * rw + 0.5 * rw;
    const double yc = -c * o_.long_corridor_spacing_m;
    for (int j = 0; j < slots; ++j) {
      const double x = first + j * rw;
      // The elevator cab occupies the +y side of corridor 0 around x = 0.
      if (c == 0 && side > 0 && std::abs(x) < 0.5 * (rw + o_.cab_width_m) + 0.5) continue;
      if (!rng_.bernoulli(o_.room_probability)) continue;
      Room room;
      const double y_near = yc + side * hw;
      const double y_far = yc + side * (hw + o_.room_depth_m);
      room.box = Box{Vec2(x - 0.5 * rw, std::min(y_near, y_far)),
                     Vec2(x + 0.5 * rw, std::max(y_near, y_far))};
      room.dark = rng_.bernoulli(o_.dark_room_fraction);
      room.door = station(c, x, PlaceKind::kDoor);
      room.centre = addPlace(Vec2(x, yc + side * (hw + 0.5 * o_.room_depth_m)), PlaceKind::kRoom);
      const int r = static_cast<int>(floor_.rooms.size());
      floor_.places[room.centre].room = r;
      if (floor_.places[room.door].kind == PlaceKind::kDoor) floor_.places[room.door].room = r;
      connect(room.door, room.centre);
      floor_.rooms.push_back(room);
    }
  }

  const BuildingOptions& o_;
  Random& rng_;
  Floor floor_;
  std::vector<std::vector<std::pair<double, int>>> stations_;  // per long corridor: (x, place)
};

}  // namespace

const char* placeKindName(PlaceKind kind) {
  switch (kind) {
    case PlaceKind::kJunction:
      return "junction";
    case PlaceKind::kDoor:
      return "door";
    case PlaceKind::kRoom:
      return "room";
    case PlaceKind::kLobby:
      return "lobby";
    case PlaceKind::kCab:
      return "cab";
  }
  return "?";
}

int Floor::roomAt(const Vec2& p) const {
  for (size_t r = 0; r < rooms.size(); ++r) {
    if (rooms[r].box.contains(p)) return static_cast<int>(r);
  }
  return -1;
}

std::vector<double> Floor::distancesFrom(int from) const {
  std::vector<double> dist(places.size(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  dist[from] = 0.0;
  open.emplace(0.0, from);
  while (!open.empty()) {
    const auto [d, p] = open.top();
    open.pop();
    if (d > dist[p]) continue;
    for (const Passage& e : passages[p]) {
      if (d + e.length_m < dist[e.to]) {
        dist[e.to] = d + e.length_m;
        open.emplace(dist[e.to], e.to);
      }
    }
  }
  return dist;
}

std::vector<int> Floor::shortestPath(int from, int to) const {
  // Dijkstra from `to`, then walk downhill from `from`: ties resolve to the lowest index, so
  // the path is a pure function of the graph.
  const std::vector<double> dist = distancesFrom(to);
  std::vector<int> path{from};
  if (!std::isfinite(dist[from])) return {};
  int p = from;
  while (p != to) {
    int next = -1;
    for (const Passage& e : passages[p]) {
      if (std::abs(dist[e.to] + e.length_m - dist[p]) < 1e-9 && (next < 0 || e.to < next))
        next = e.to;
    }
    if (next < 0) return {};  // cannot happen on a consistent graph
    path.push_back(next);
    p = next;
  }
  return path;
}

double Floor::passageLength() const {
  double sum = 0.0;
  for (const auto& list : passages) {
    for (const Passage& e : list) sum += e.length_m;
  }
  return 0.5 * sum;
}

Status BuildingOptions::validate() const {
  if (floors < 1) return makeError("floors: must be >= 1, got ", floors);
  if (main_floor < 0 || main_floor >= floors) {
    return makeError("main_floor: must be in [0, floors), got ", main_floor);
  }
  if (!(storey_height_m > 0.0)) return makeError("storey_height_m: must be > 0");
  if (!(storey_jitter_m >= 0.0 && storey_jitter_m < 0.5 * storey_height_m)) {
    return makeError("storey_jitter_m: must be in [0, storey_height_m / 2)");
  }
  if (!(corridor_half_width_m > 0.0)) return makeError("corridor_half_width_m: must be > 0");
  if (!(room_width_m > 0.0 && room_depth_m > 0.0)) {
    return makeError("room_width_m: room width and depth must be > 0");
  }
  if (!(cross_corridor_spacing_m >= 2.0 * corridor_half_width_m + room_width_m)) {
    return makeError("cross_corridor_spacing_m: must leave room for one room between corridors");
  }
  if (!(long_corridor_spacing_m >= 2.0 * (corridor_half_width_m + room_depth_m))) {
    return makeError(
        "long_corridor_spacing_m: must be >= 2 * (corridor_half_width_m + room_depth_m)");
  }
  if (main_cross_corridors < 2) return makeError("main_cross_corridors: must be >= 2");
  if (main_long_corridors < 1) return makeError("main_long_corridors: must be >= 1");
  if (min_cross_corridors < 2 || max_cross_corridors < min_cross_corridors) {
    return makeError("min_cross_corridors: need 2 <= min_cross_corridors <= max_cross_corridors");
  }
  if (max_long_corridors < 1) return makeError("max_long_corridors: must be >= 1");
  for (double p : {room_probability, dark_room_fraction, blank_wall_fraction}) {
    if (!(p >= 0.0 && p <= 1.0)) {
      return makeError("room_probability: probabilities and fractions must be in [0, 1]");
    }
  }
  if (!(cab_width_m > 0.0 && cab_depth_m > 0.0 &&
        cab_width_m < cross_corridor_spacing_m - 2.0 * corridor_half_width_m)) {
    return makeError("cab_width_m: the cab must fit between two cross corridors");
  }
  return Ok{};
}

int Building::nearestFloor(double z) const {
  int best = 0;
  for (size_t i = 1; i < floors.size(); ++i) {
    if (std::abs(floors[i].height_m - z) < std::abs(floors[best].height_m - z))
      best = static_cast<int>(i);
  }
  return best;
}

Building generateBuilding(const BuildingOptions& o, Random& rng) {
  Building b;
  b.main_floor = o.main_floor;
  FloorBuilder builder(o, rng);
  double height = 0.0;
  for (int f = 0; f < o.floors; ++f) {
    if (f > 0) height += o.storey_height_m + rng.uniform(-o.storey_jitter_m, o.storey_jitter_m);
    const bool main = f == o.main_floor;
    const int n_cross =
        main ? o.main_cross_corridors
             : static_cast<int>(rng.integer(o.min_cross_corridors, o.max_cross_corridors));
    const int n_long =
        main ? o.main_long_corridors : static_cast<int>(rng.integer(1, o.max_long_corridors));
    // The shaft (x = 0) lies midway between cross corridors j and j + 1.
    const int j = main ? (n_cross - 2) / 2 : static_cast<int>(rng.index(n_cross - 1));
    const double x_min = -(j + 0.5) * o.cross_corridor_spacing_m;
    b.floors.push_back(builder.build(f, height, n_cross, n_long, x_min));
  }
  // Home: a junction of the main floor.
  const Floor& main = b.floors[o.main_floor];
  std::vector<int> junctions;
  for (size_t p = 0; p < main.places.size(); ++p) {
    if (main.places[p].kind == PlaceKind::kJunction) junctions.push_back(static_cast<int>(p));
  }
  b.home_place = junctions[rng.index(static_cast<int64_t>(junctions.size()))];
  return b;
}

Building flatBuilding() {
  Building b;
  b.floors.emplace_back();
  b.main_floor = 0;
  return b;
}

}  // namespace evermap::sim
