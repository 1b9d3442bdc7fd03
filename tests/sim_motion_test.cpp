// Building and motion of the measurement-level simulator: motion profiles are consistent
// (velocity is the derivative of position, limits hold), the building is walkable and its
// shaft lines up across floors, and planned sessions move continuously along passages.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <tuple>

#include "sim_test_support.h"
#include "tools/sim/building.h"
#include "tools/sim/motion.h"
#include "tools/sim/run.h"

namespace evermap::sim {
namespace {

void expectConsistentProfile(const MotionProfile& p, double distance, double speed, double accel) {
  EXPECT_NEAR(p.position(p.duration()), distance, 1e-12);
  EXPECT_EQ(p.position(0.0), 0.0);
  EXPECT_EQ(p.velocity(p.duration()), 0.0);
  const double h = 1e-6;
  for (double t = 0.01; t < p.duration(); t += p.duration() / 97.0) {
    EXPECT_NEAR((p.position(t + h) - p.position(t - h)) / (2 * h), p.velocity(t), 1e-5) << t;
    EXPECT_LE(p.velocity(t), speed + 1e-12);
    EXPECT_LE(std::abs(p.acceleration(t)), accel + 1e-12);
  }
  // Away from the kinks of the trapezoid, acceleration is the derivative of velocity.
  for (double t = 0.013; t < p.duration(); t += p.duration() / 89.0) {
    const double numeric = (p.velocity(t + h) - p.velocity(t - h)) / (2 * h);
    if (std::abs(numeric - p.acceleration(t)) > 1e-4) {
      EXPECT_NEAR(p.velocity(t + h) - p.velocity(t - h), 2 * h * p.acceleration(t), 4 * h * accel)
          << t;
    }
  }
}

TEST(SimMotion, ProfilesReachTheirDistanceWithinTheirLimits) {
  for (auto shape : {MotionProfile::Shape::kTrapezoid, MotionProfile::Shape::kSmooth}) {
    for (double distance : {0.05, 1.0, 4.4, 30.0}) {
      const MotionProfile p(shape, distance, 1.5, 0.8);
      expectConsistentProfile(p, distance, 1.5, 0.8);
    }
  }
  // The smooth (elevator) ramp peaks at the given acceleration and averages half of it.
  const MotionProfile ride(MotionProfile::Shape::kSmooth, 20.0, 2.0, 1.0);
  EXPECT_NEAR(ride.peakSpeed(), 2.0, 1e-12);
  double peak = 0.0;
  for (double t = 0.0; t < ride.duration(); t += 0.001) peak = std::max(peak, ride.acceleration(t));
  EXPECT_NEAR(peak, 1.0, 1e-5);
  EXPECT_NEAR(ride.duration(), 2 * (2 * 2.0 / 1.0) + (20.0 - 2 * 4.0) / 2.0, 1e-12);
}

TEST(SimBuilding, FloorsAreWalkableAndTheShaftLinesUp) {
  Random rng(5);
  const BuildingOptions o;
  const Building b = generateBuilding(o, rng);
  ASSERT_EQ(b.floors.size(), 10u);
  for (size_t i = 0; i < b.floors.size(); ++i) {
    const Floor& f = b.floors[i];
    if (i > 0) {
      const double storey = f.height_m - b.floors[i - 1].height_m;
      EXPECT_GE(storey, o.storey_height_m - o.storey_jitter_m);
      EXPECT_LE(storey, o.storey_height_m + o.storey_jitter_m);
    }
    for (double d : f.distancesFrom(f.lobby))
      EXPECT_TRUE(std::isfinite(d)) << "floor " << i << " is not connected";
    EXPECT_TRUE(f.places[f.lobby].xy.isZero());
    EXPECT_TRUE(f.places[f.cab_place].xy.isApprox(b.floors[0].places[b.floors[0].cab_place].xy));
    EXPECT_TRUE(f.cab.contains(f.places[f.cab_place].xy));
    for (const Room& r : f.rooms) {
      EXPECT_TRUE(r.box.contains(f.places[r.centre].xy));
      EXPECT_FALSE(r.box.contains(f.places[r.door].xy))
          << "the door is on the corridor, outside the room";
      EXPECT_TRUE(f.footprint.contains(r.box.min) && f.footprint.contains(r.box.max));
      EXPECT_LT(f.roomAt(f.places[f.lobby].xy), 0);
    }
    for (const Place& p : f.places) {
      if (p.kind == PlaceKind::kJunction) {
        EXPECT_LT(f.roomAt(p.xy), 0) << "a room covers a corridor";
      }
    }
  }
  EXPECT_NEAR(
      b.floors[o.main_floor].footprint.max.x() - b.floors[o.main_floor].footprint.min.x(),
      (o.main_cross_corridors - 1) * o.cross_corridor_spacing_m + 2 * o.corridor_half_width_m,
      1e-9);
  EXPECT_EQ(b.floors[b.main_floor].places[b.home_place].kind, PlaceKind::kJunction);
}

// Distance from p to the segment [a, b].
double segmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double t = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (a + t * d - p).norm();
}

TEST(SimMotion, SessionsMoveContinuouslyAlongPassages) {
  const auto plan = RunPlan::create(testing::smallRun(31));
  ASSERT_TRUE(plan.ok());
  const Building& b = plan->building();
  const SessionPlan s = plan->session(1);
  const Trajectory& t = *s.trajectory;
  BodyState prev = t.at(t.startUtime());
  const int64_t step = 20000;
  double driven = 0.0;
  for (int64_t u = t.startUtime() + step; u <= t.endUtime(); u += step) {
    const BodyState cur = t.at(u);
    const Vec3 move = cur.world_T_body.translation() - prev.world_T_body.translation();
    EXPECT_LE(move.head<2>().norm(),
              0.55 * 1.15 * 0.02 + 1e-9);              // never faster than the cruise speed
    EXPECT_LE(std::abs(move.z()), 2.0 * 0.02 + 1e-9);  // nor than the elevator
    driven += move.head<2>().norm();
    if (cur.floor >= 0) {
      const Floor& f = b.floors[cur.floor];
      EXPECT_NEAR(cur.world_T_body.translation().z(), f.height_m, 1e-9);
      double nearest = 1e9;
      const Vec2 p = cur.world_T_body.translation().head<2>();
      for (size_t i = 0; i < f.places.size(); ++i) {
        for (const Passage& e : f.passages[i]) {
          nearest = std::min(nearest, segmentDistance(p, f.places[i].xy, f.places[e.to].xy));
        }
      }
      EXPECT_LT(nearest, 1e-6) << "off the walkable passages";
      if (cur.in_cab) {
        EXPECT_TRUE(f.cab.contains(p));
      }
    }
    prev = cur;
  }
  EXPECT_NEAR(driven, s.distance_m, 0.01 * s.distance_m);
  EXPECT_GT(s.rides.size(), 0u);
}

TEST(SimMotion, ExplorationToursDriveEveryPassageBothWays) {
  SimOptions o = testing::smallRun(31);
  o.patrol.explore_tours = true;
  o.patrol.explore_sessions = 2;
  const auto plan = RunPlan::create(o);
  ASSERT_TRUE(plan.ok());
  const Building& b = plan->building();
  // Directed passages driven in the exploration sessions, per floor, as place pairs.
  std::set<std::tuple<int, int, int>> driven;
  auto placeAt = [&](int floor, const Vec2& p) {
    const Floor& f = b.floors[floor];
    for (size_t i = 0; i < f.places.size(); ++i)
      if ((f.places[i].xy - p).norm() < 1e-9) return static_cast<int>(i);
    return -1;
  };
  for (int k = 0; k < o.patrol.explore_sessions; ++k) {
    const SessionPlan s = plan->session(k);
    const auto& segments = dynamic_cast<const SegmentTrajectory&>(*s.trajectory).segments();
    for (const Segment& g : segments) {
      if (g.kind == Segment::Kind::kDrive)
        driven.emplace(g.floor, placeAt(g.floor, g.from), placeAt(g.floor, g.to));
    }
  }
  // Every passage between places other than the cab, on every floor, both ways.
  int passages = 0;
  for (const Floor& f : b.floors) {
    for (size_t i = 0; i < f.places.size(); ++i) {
      for (const Passage& e : f.passages[i]) {
        if (static_cast<int>(i) == f.cab_place || e.to == f.cab_place) continue;
        ++passages;
        EXPECT_TRUE(driven.count({f.index, static_cast<int>(i), e.to}))
            << "floor " << f.index << ": " << i << " -> " << e.to;
      }
    }
  }
  EXPECT_GT(passages, 20);
}

TEST(SimMotion, SameSeedPlansTheSameBuildingAndSessions) {
  const auto a = RunPlan::create(testing::smallRun(32));
  const auto b = RunPlan::create(testing::smallRun(32));
  ASSERT_TRUE(a.ok() && b.ok());
  const SessionPlan sa = a->session(1);
  const SessionPlan sb = b->session(1);
  ASSERT_EQ(sa.trajectory->endUtime(), sb.trajectory->endUtime());
  for (int64_t u = sa.trajectory->startUtime(); u <= sa.trajectory->endUtime(); u += 1000000) {
    EXPECT_EQ(sa.trajectory->at(u).world_T_body.matrix(),
              sb.trajectory->at(u).world_T_body.matrix());
  }
}

}  // namespace
}  // namespace evermap::sim
