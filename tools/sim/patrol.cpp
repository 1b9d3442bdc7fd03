#include "tools/sim/patrol.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <set>

namespace evermap::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// Appends segments while tracking where the robot is.
class SessionBuilder {
 public:
  SessionBuilder(const Building& b, const PatrolOptions& p, const ElevatorOptions& e, Random& rng,
                 int64_t start_utime)
      : b_(b), p_(p), e_(e), rng_(rng), start_utime_(start_utime) {}

  void start(int floor, int place, double yaw) {
    floor_ = floor;
    place_ = place;
    yaw_ = yaw;
    xy_ = b_.floors[floor].places[place].xy;
    visited_.insert(floor);
  }

  double now() const { return t_; }
  int floor() const { return floor_; }

  void wait(double duration_s, bool in_cab) {
    if (duration_s <= 0.0) return;
    Segment s = base(Segment::Kind::kWait);
    s.duration_s = duration_s;
    s.in_cab = in_cab;
    push(s);
  }

  void turnTo(double yaw, bool blank_wall, bool in_cab) {
    const double delta = core::wrapAngle(yaw - yaw_);
    if (std::abs(delta) < 1e-9) return;
    Segment s = base(Segment::Kind::kTurn);
    s.yaw1 = yaw_ + delta;
    s.profile = MotionProfile(MotionProfile::Shape::kTrapezoid, delta, p_.turn_rate_radps,
                              p_.turn_accel_radps2);
    s.duration_s = s.profile.duration();
    s.blank_wall = blank_wall;
    s.in_cab = in_cab;
    push(s);
    yaw_ = core::wrapAngle(yaw_ + delta);
  }

  // Drives along the shortest path to `goal` on the current floor.
  void driveTo(int goal) { drivePath(b_.floors[floor_].shortestPath(place_, goal)); }

  // Drives every passage between places of `allowed` (on the current floor, reachable from
  // here) once in each direction and comes back: Hierholzer's algorithm on the doubled
  // passage graph, whose in- and out-degrees are equal at every place, so the circuit exists.
  // The next passage out of a place is drawn at random among those not driven yet.
  void explore(const std::vector<int>& allowed) {
    const Floor& f = b_.floors[floor_];
    std::vector<char> in(f.places.size(), 0);
    for (int p : allowed) in[static_cast<size_t>(p)] = 1;
    if (!in[static_cast<size_t>(place_)]) return;
    std::vector<std::vector<int>> out(f.places.size());
    for (size_t p = 0; p < f.places.size(); ++p) {
      if (!in[p]) continue;
      for (const Passage& q : f.passages[p]) {
        if (in[static_cast<size_t>(q.to)]) out[p].push_back(q.to);
      }
      for (size_t k = out[p].size(); k > 1; --k)
        std::swap(out[p][k - 1], out[p][rng_.index(static_cast<int64_t>(k))]);
    }
    std::vector<size_t> next(f.places.size(), 0);
    std::vector<int> stack{place_}, circuit;
    while (!stack.empty()) {
      const auto v = static_cast<size_t>(stack.back());
      if (next[v] < out[v].size()) {
        stack.push_back(out[v][next[v]++]);
      } else {
        circuit.push_back(stack.back());
        stack.pop_back();
      }
    }
    std::reverse(circuit.begin(), circuit.end());
    drivePath(circuit);
  }

  // Drives from place to place along `path` (consecutive places joined by a passage),
  // turning in place at each.
  void drivePath(const std::vector<int>& path) {
    if (path.empty()) return;
    const Floor& f = b_.floors[floor_];
    const double speed = p_.drive_speed_mps * rng_.uniform(0.85, 1.15);
    for (size_t i = 1; i < path.size(); ++i) {
      const Vec2 from = f.places[path[i - 1]].xy;
      const Vec2 to = f.places[path[i]].xy;
      const double length = (to - from).norm();
      if (length < 1e-9) continue;
      const Vec2 d = to - from;
      turnTo(std::atan2(d.y(), d.x()), f.places[path[i - 1]].blank_wall,
             f.places[path[i - 1]].kind == PlaceKind::kCab);
      Segment s = base(Segment::Kind::kDrive);
      s.to = to;
      s.profile =
          MotionProfile(MotionProfile::Shape::kTrapezoid, length, speed, p_.drive_accel_mps2);
      s.duration_s = s.profile.duration();
      push(s);
      xy_ = to;
      odometer_ += length;
    }
    place_ = path.back();
  }

  void elevatorTrip(int target) {
    if (target == floor_) return;
    const Floor& here = b_.floors[floor_];
    driveTo(here.lobby);
    wait(rng_.uniform(0.0, e_.call_wait_max_s), false);
    driveTo(here.cab_place);
    turnTo(-0.5 * kPi, false, true);  // face the door, which opens onto the corridor (-y)
    wait(rng_.uniform(e_.door_wait_min_s, e_.door_wait_max_s), true);
    std::vector<int> stops;
    if (std::abs(target - floor_) > 1 && rng_.bernoulli(e_.intermediate_stop_probability)) {
      const int lo = std::min(target, floor_) + 1;
      const int hi = std::max(target, floor_) - 1;
      stops.push_back(static_cast<int>(rng_.integer(lo, hi)));
    }
    stops.push_back(target);
    for (size_t i = 0; i < stops.size(); ++i) {
      ride(stops[i]);
      const bool last = i + 1 == stops.size();
      wait(last ? rng_.uniform(e_.door_wait_min_s, e_.door_wait_max_s)
                : rng_.uniform(e_.stop_dwell_min_s, e_.stop_dwell_max_s),
           true);
    }
    place_ = b_.floors[floor_].cab_place;
    driveTo(b_.floors[floor_].lobby);
  }

  // Visits `goals` random places among `allowed` on the current floor, stopping at `deadline`.
  void patrol(const std::vector<int>& allowed, int goals, double deadline_s) {
    for (int g = 0; g < goals && t_ < deadline_s; ++g) {
      int goal = allowed[rng_.index(static_cast<int64_t>(allowed.size()))];
      if (goal == place_) continue;
      driveTo(goal);
      wait(rng_.uniform(p_.pause_min_s, p_.pause_max_s), false);
    }
  }

  SessionPlan finish(int index) {
    SessionPlan plan;
    plan.index = index;
    plan.rides = std::move(rides_);
    plan.distance_m = odometer_;
    plan.floors_visited.assign(visited_.begin(), visited_.end());
    FloorRoughness roughness;
    roughness.amplitude_rad = p_.roughness_rad;
    plan.trajectory =
        std::make_shared<SegmentTrajectory>(start_utime_, std::move(segments_), roughness);
    return plan;
  }

 private:
  Segment base(Segment::Kind kind) const {
    Segment s;
    s.kind = kind;
    s.t0_s = t_;
    s.floor = floor_;
    s.floor_to = floor_;
    s.from = xy_;
    s.to = xy_;
    s.yaw0 = yaw_;
    s.yaw1 = yaw_;
    s.z0 = b_.floors[floor_].height_m;
    s.z1 = s.z0;
    s.odometer0_m = odometer_;
    return s;
  }

  void push(const Segment& s) {
    segments_.push_back(s);
    t_ += s.duration_s;
  }

  void ride(int to) {
    Segment s = base(Segment::Kind::kRide);
    s.floor_to = to;
    s.z1 = b_.floors[to].height_m;
    s.in_cab = true;
    s.profile = MotionProfile(MotionProfile::Shape::kSmooth, s.z1 - s.z0,
                              rng_.uniform(e_.speed_min_mps, e_.speed_max_mps),
                              rng_.uniform(e_.accel_min_mps2, e_.accel_max_mps2));
    s.duration_s = s.profile.duration();
    ElevatorRide r;
    r.start_utime = start_utime_ + static_cast<int64_t>(std::floor(s.t0_s * 1e6));
    r.end_utime = start_utime_ + static_cast<int64_t>(std::ceil((s.t0_s + s.duration_s) * 1e6));
    r.floor_from = floor_;
    r.floor_to = to;
    r.z_from = s.z0;
    r.z_to = s.z1;
    rides_.push_back(r);
    push(s);
    floor_ = to;
    visited_.insert(to);
  }

  const Building& b_;
  const PatrolOptions& p_;
  const ElevatorOptions& e_;
  Random& rng_;
  int64_t start_utime_;
  double t_ = 0.0;
  int floor_ = 0;
  int place_ = 0;
  Vec2 xy_ = Vec2::Zero();
  double yaw_ = 0.0;
  double odometer_ = 0.0;
  std::vector<Segment> segments_;
  std::vector<ElevatorRide> rides_;
  std::set<int> visited_;
};

// Goal places of a floor: every place but the cab.
std::vector<int> goalPlaces(const Floor& f) {
  std::vector<int> out;
  for (size_t p = 0; p < f.places.size(); ++p) {
    if (f.places[p].kind != PlaceKind::kCab) out.push_back(static_cast<int>(p));
  }
  return out;
}

// The part of the main floor open to session `index`: the places nearest to home first.
std::vector<int> exploredPlaces(const Building& b, const PatrolOptions& p, int index) {
  const Floor& f = b.floors[b.main_floor];
  std::vector<int> places = goalPlaces(f);
  const std::vector<double> dist = f.distancesFrom(b.home_place);
  std::stable_sort(places.begin(), places.end(), [&](int a, int c) { return dist[a] < dist[c]; });
  const double share = std::min(1.0, static_cast<double>(index + 1) / p.explore_sessions);
  const size_t n = std::max<size_t>(2, static_cast<size_t>(std::ceil(share * places.size())));
  places.resize(std::min(n, places.size()));
  return places;
}

}  // namespace

Status PatrolOptions::validate() const {
  if (sessions < 1) return makeError("sessions: must be >= 1, got ", sessions);
  if (!(total_hours > 0.0)) return makeError("total_hours: must be > 0");
  if (!(session_jitter >= 0.0 && session_jitter < 1.0))
    return makeError("session_jitter: must be in [0, 1)");
  if (!(span_days >= 0.0)) return makeError("span_days: must be >= 0");
  if (start_utime < 0) return makeError("start_utime: must be >= 0");
  if (!(drive_speed_mps > 0.0 && drive_accel_mps2 > 0.0)) {
    return makeError("drive_speed_mps: speed and acceleration must be > 0");
  }
  if (!(turn_rate_radps > 0.0 && turn_accel_radps2 > 0.0)) {
    return makeError("turn_rate_radps: turn rate and acceleration must be > 0");
  }
  if (!(pause_min_s >= 0.0 && pause_max_s >= pause_min_s)) {
    return makeError("pause_min_s: need 0 <= pause_min_s <= pause_max_s");
  }
  if (goals_min < 1 || goals_max < goals_min)
    return makeError("goals_min: need 1 <= goals_min <= goals_max");
  if (!(other_floor_probability >= 0.0 && other_floor_probability <= 1.0)) {
    return makeError("other_floor_probability: must be in [0, 1]");
  }
  if (explore_sessions < 1) return makeError("explore_sessions: must be >= 1");
  if (!(roughness_rad >= 0.0 && roughness_rad < 0.2))
    return makeError("roughness_rad: must be in [0, 0.2)");
  return Ok{};
}

Status ElevatorOptions::validate() const {
  if (!(accel_min_mps2 > 0.0 && accel_max_mps2 >= accel_min_mps2)) {
    return makeError("accel_min_mps2: need 0 < accel_min_mps2 <= accel_max_mps2");
  }
  if (!(speed_min_mps > 0.0 && speed_max_mps >= speed_min_mps)) {
    return makeError("speed_min_mps: need 0 < speed_min_mps <= speed_max_mps");
  }
  if (!(call_wait_max_s >= 0.0)) return makeError("call_wait_max_s: must be >= 0");
  if (!(door_wait_min_s >= 0.0 && door_wait_max_s >= door_wait_min_s)) {
    return makeError("door_wait_min_s: need 0 <= door_wait_min_s <= door_wait_max_s");
  }
  if (!(intermediate_stop_probability >= 0.0 && intermediate_stop_probability <= 1.0)) {
    return makeError("intermediate_stop_probability: must be in [0, 1]");
  }
  if (!(stop_dwell_min_s >= 0.0 && stop_dwell_max_s >= stop_dwell_min_s)) {
    return makeError("stop_dwell_min_s: need 0 <= stop_dwell_min_s <= stop_dwell_max_s");
  }
  return Ok{};
}

std::vector<SessionSlot> scheduleSessions(const Building& building, const PatrolOptions& p,
                                          Random& rng) {
  std::vector<SessionSlot> slots(p.sessions);
  double sum = 0.0;
  for (auto& s : slots) {
    s.duration_s = 1.0 + rng.uniform(-p.session_jitter, p.session_jitter);
    sum += s.duration_s;
  }
  const double total_s = p.total_hours * 3600.0;
  const double day_us = 86400e6;
  const double gap_days = p.sessions > 1 ? p.span_days / (p.sessions - 1) : 0.0;
  int64_t earliest = p.start_utime;
  for (int i = 0; i < p.sessions; ++i) {
    SessionSlot& s = slots[i];
    s.duration_s *= total_s / sum;
    const int64_t planned = p.start_utime + static_cast<int64_t>(i * gap_days * day_us) +
                            (i > 0 ? static_cast<int64_t>(rng.uniform(0.0, 6.0) * 3600e6) : 0);
    s.start_utime = std::max(planned, earliest);
    // Sessions never overlap: the next may start a minute after this one could end (patrols
    // overrun their nominal length by at most one excursion, bounded generously here).
    earliest = s.start_utime + static_cast<int64_t>((2.0 * s.duration_s + 3600.0) * 1e6);
  }
  // Every floor but the main one is visited at least once: one new floor per session from
  // session 1 on (all in session 0 when there is only one session).
  std::vector<int> others;
  for (size_t f = 0; f < building.floors.size(); ++f) {
    if (static_cast<int>(f) != building.main_floor) others.push_back(static_cast<int>(f));
  }
  for (size_t k = others.size(); k > 1; --k)
    std::swap(others[k - 1], others[rng.index(static_cast<int64_t>(k))]);
  // With exploration tours the first visits fall in the exploration sessions.
  const int spread = p.explore_tours ? std::min(p.sessions, p.explore_sessions) : p.sessions;
  for (size_t k = 0; k < others.size(); ++k) {
    const int session = spread <= 1 ? 0 : 1 + static_cast<int>(k % (spread - 1));
    slots[session].must_visit.push_back(others[k]);
  }
  return slots;
}

SessionPlan planSession(const Building& b, const PatrolOptions& p, const ElevatorOptions& e,
                        int index, const SessionSlot& slot, Random& rng) {
  SessionBuilder s(b, p, e, rng, slot.start_utime);
  s.start(b.main_floor, b.home_place, rng.uniform(-kPi, kPi));
  s.wait(2.0, false);  // the sensors settle before the robot moves
  const std::vector<int> explored = exploredPlaces(b, p, index);
  if (p.explore_tours && index < p.explore_sessions) s.explore(explored);
  std::vector<int> must = slot.must_visit;
  const double deadline = slot.duration_s;
  // Floors this session must visit are visited even if that overruns the nominal length.
  while (s.now() < deadline || !must.empty()) {
    const bool forced = !must.empty() && (rng.bernoulli(0.3) || s.now() > 0.5 * deadline);
    const bool visit = b.floors.size() > 1 && (forced || rng.bernoulli(p.other_floor_probability));
    const int goals = static_cast<int>(rng.integer(p.goals_min, p.goals_max));
    if (!visit) {
      s.patrol(explored, goals, deadline);
      continue;
    }
    int target;
    bool first_visit = false;
    if (!must.empty()) {
      target = must.front();
      must.erase(must.begin());
      first_visit = p.explore_tours;
    } else {
      do {
        target = static_cast<int>(rng.index(static_cast<int64_t>(b.floors.size())));
      } while (target == b.main_floor);
    }
    s.elevatorTrip(target);
    // A visit lasts its patrol even past the deadline: the robot does not abandon a floor.
    if (first_visit)
      s.explore(goalPlaces(b.floors[target]));
    else
      s.patrol(goalPlaces(b.floors[target]), goals, s.now() + deadline);
    s.elevatorTrip(b.main_floor);
  }
  s.driveTo(b.home_place);
  s.wait(2.0, false);
  return s.finish(index);
}

}  // namespace evermap::sim
