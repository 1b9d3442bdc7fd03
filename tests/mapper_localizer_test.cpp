// mapper-proc/localizer: a robot driven along a stored corridor of nodes is placed by two
// registrations that agree, tracks the truth while registrations correct it, counts and never
// applies one the map gate refuses, and stops calling itself localized when it dead-reckons
// past the bound, and is not localized from the first sign of an elevator ride
// (docs/localization.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include <evermap/register_result_t.hpp>

#include "mapper-proc/localizer.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper {
namespace {

using namespace testing;

constexpr int64_t kSecond = 1000000;

// A stored corridor: nodes 0..9 at x = 0..9 m on floor 0, heading +x.
MapSnapshot corridor() {
  MapSnapshot map;
  map.floors = {{0, 0.0}};
  map.sessions = {{0, 0}};
  for (int i = 0; i < 10; ++i) {
    StoredNode n;
    n.node.id = i;
    n.node.keyframe_utime = i * kSecond;
    n.world_T_body = planar(i, 0, 0);
    map.nodes.push_back(n);
  }
  return map;
}

// The robot driven along +x from x0, 0.5 m per keyframe (one a second), answering each request
// with the true registration (shifted by `lie` when given) unless `answer` is false.
class Drive {
 public:
  Drive(Localizer& l, double x0) : l_(l), x_(x0) {
    EXPECT_TRUE(l_.onVo(voRestart(t_)).ok());
    ref_ = t_;
    answerAll(false, SE3d());  // VO's first frame: nothing seen yet
  }
  // One keyframe step; returns whether a request went out.
  int64_t now() const { return t_; }
  bool step(bool answer = true, const SE3d& lie = SE3d()) {
    t_ += kSecond;
    x_ += 0.5;
    EXPECT_TRUE(l_.onVo(voMsg(t_, ref_, planar(0.5, 0, 0), 0.01, true)).ok());
    ref_ = t_;
    return answerAll(answer, lie);
  }
  double x() const { return x_; }

 private:
  bool answerAll(bool answer, const SE3d& lie) {
    bool asked = false;
    for (const register_request_t& r : l_.takeRequests()) {
      asked = true;
      register_result_t a{};
      a.request_id = r.request_id;
      a.keyframe_utime = r.keyframe_utime;
      const int64_t node = r.mode == register_request_t::MODE_NODE
                               ? r.target_node_id
                               : std::clamp<int64_t>(std::lround(x_), 0, 9);
      a.node_id = node;
      a.status = answer ? register_result_t::STATUS_OK : register_result_t::STATUS_NO_CANDIDATE;
      messages::putPose(lie * planar(x_ - static_cast<double>(node), 0, 0), a.translation,
                        a.orientation);
      for (int i = 0; i < 6; ++i) a.covariance[7 * i] = 1e-4;
      EXPECT_TRUE(l_.onRegisterResult(a).ok());
      // A failed node-mode request is followed by a global one: answered the same way.
      for (const register_request_t& g : l_.takeRequests()) {
        a.request_id = g.request_id;
        a.status = register_result_t::STATUS_NO_CANDIDATE;
        EXPECT_TRUE(l_.onRegisterResult(a).ok());
      }
    }
    return asked;
  }

  Localizer& l_;
  double x_;
  int64_t t_ = 100 * kSecond;
  int64_t ref_ = 0;
};

// A localizer of `map` with the robot driven from x = 1.2 and placed by two agreeing steps.
struct Placed {
  explicit Placed(const MapSnapshot& map, const MapperOptions& o = {})
      : l(o), loaded(l.load(map).ok()), drive(l, 1.2) {
    drive.step();
    drive.step();
  }
  Localizer l;
  bool loaded;
  Drive drive;
};

TEST(Localizer, ALostRobotIsPlacedByTwoRegistrationsThatAgreeAndThenTracksTheTruth) {
  Localizer l(MapperOptions{});
  ASSERT_TRUE(l.load(corridor()).ok());
  Drive drive(l, 1.2);
  EXPECT_FALSE(l.placed());
  drive.step();  // the first registration: a candidate only
  EXPECT_FALSE(l.localized());
  drive.step();  // the second agrees with it through odometry
  ASSERT_TRUE(l.localized());
  EXPECT_EQ(l.stats().placements, 1);
  for (int i = 0; i < 6; ++i) drive.step();
  EXPECT_TRUE(l.localized());
  EXPECT_GE(l.stats().corrections, 5);
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x(), 1e-6);
  EXPECT_EQ(l.floor(), 0);
}

TEST(Localizer, ARegistrationTheGateRefusesIsCountedAndNeverApplied) {
  Placed placed(corridor());
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  drive.step(true, planar(2.0, 0, 0));  // 2 m off: a false match
  EXPECT_EQ(l.stats().refused_gate, 1);
  EXPECT_TRUE(l.localized());
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x(), 1e-6);
}

// The pose drifted (here: every registration says the robot is 1.5 m further than tracked):
// the gate refuses each alone; two that agree with each other, once none has confirmed the
// pose for recovery_quiet_s (3 s), re-track it.
TEST(Localizer, TwoRefusedRegistrationsThatAgreeReTrackADriftedPose) {
  Placed placed(corridor());
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  const SE3d ahead = planar(1.5, 0, 0);
  drive.step(true, ahead);
  drive.step(true, ahead);
  EXPECT_EQ(l.stats().gate_recoveries, 0) << "2 s after the last confirmation: not yet";
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x(), 1e-6);
  drive.step(true, ahead);
  EXPECT_EQ(l.stats().gate_recoveries, 1);
  EXPECT_EQ(l.stats().refused_gate, 3);
  EXPECT_TRUE(l.localized());
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x() + 1.5, 1e-6);
}

// Repeated texture: false matches one texture period (12 m) away agree with each other. The
// jump is more than odometry could have drifted (3 m + 15 % of the distance): refused.
TEST(Localizer, AgreeingMatchesFartherThanOdometryCouldDriftMoveNothing) {
  Placed placed(corridor());
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  for (int i = 0; i < 4; ++i) drive.step(true, planar(12.0, 0, 0));
  EXPECT_EQ(l.stats().gate_recoveries, 0);
  EXPECT_GE(l.stats().recoveries_too_far, 1);
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x(), 1e-6);
}

// Dead reckoning's covariance grows with the distance travelled since the last registration
// applied (localize.drift_per_m), beyond VO's own (0.01 m per step here, which alone grows with
// its square root); past max_sigma_m the pose is no longer localized, but still given.
TEST(Localizer, DeadReckoningPastTheBoundIsNoLongerLocalizedButStillGivesThePose) {
  MapperOptions o;
  o.localize.drift_per_m = 0.1;
  o.localize.max_sigma_m = 0.22;
  Placed placed(corridor(), o);
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  drive.step();  // a correction: the distance counts from here
  ASSERT_GE(l.stats().corrections, 1);
  const double sigma_at_fix = std::sqrt(l.pose().covariance(0, 0));
  for (int i = 0; i < 4; ++i) drive.step(false);  // 2 m without a registration, then 2.5
  const double sigma_2m = std::sqrt(l.pose().covariance(0, 0));
  EXPECT_GT(sigma_2m, 0.2);
  EXPECT_LT(sigma_2m, 0.2 + sigma_at_fix + 0.03);
  EXPECT_TRUE(l.localized());
  drive.step(false);
  EXPECT_FALSE(l.localized());
  EXPECT_TRUE(l.placed());
  EXPECT_EQ(l.stats().unlocalized, 1);
  EXPECT_NEAR(l.pose().mean.translation().x(), drive.x(), 1e-6);  // dead reckoning
  EXPECT_GT(std::sqrt(l.pose().covariance(0, 0)), 0.25);
}

// Without the drift, VO's covariance alone (0.01 m per step) keeps the same run localized: the
// distance is what ends it above.
TEST(Localizer, WithoutDriftVosOwnCovarianceGrowsTooSlowlyToEndLocalization) {
  MapperOptions o;
  o.localize.drift_per_m = 0.0;
  o.localize.drift_deg_per_m = 0.0;
  o.localize.max_sigma_m = 0.22;
  Placed placed(corridor(), o);
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  for (int i = 0; i < 5; ++i) placed.drive.step(false);
  EXPECT_TRUE(placed.l.localized());
  EXPECT_LT(std::sqrt(placed.l.pose().covariance(0, 0)), 0.05);
}

// The yaw's drift (localize.drift_deg_per_m) grows the yaw's variance by (rate x distance)²,
// and past max_sigma_deg the pose is no longer localized.
TEST(Localizer, YawDriftGrowsWithTheDistanceAndEndsLocalization) {
  MapperOptions without;
  without.localize.drift_per_m = 0.0;
  without.localize.drift_deg_per_m = 0.0;
  without.localize.max_sigma_deg = 3.0;
  MapperOptions with = without;
  with.localize.drift_deg_per_m = 1.5;
  Placed a(corridor(), without), b(corridor(), with);
  ASSERT_TRUE(a.loaded && a.l.localized() && b.loaded && b.l.localized());
  for (int i = 0; i < 5; ++i) {  // 2.5 m without a registration
    a.drive.step(false);
    b.drive.step(false);
  }
  const double drift_rad = 1.5 * 2.5 * std::numbers::pi / 180.0;
  EXPECT_NEAR(b.l.pose().covariance(5, 5) - a.l.pose().covariance(5, 5), drift_rad * drift_rad,
              1e-9);
  EXPECT_TRUE(a.l.localized());
  EXPECT_FALSE(b.l.localized());
}

// The map gate tests a registration against the prediction with the drift: after 2 m of dead
// reckoning a registration 0.3 m from the prediction is within it (sigma 0.2 m) and corrects
// the pose; with VO's covariance alone (2 cm) it is refused.
TEST(Localizer, TheMapGateWeighsThePredictionWithTheDrift) {
  MapperOptions without;
  without.localize.drift_per_m = 0.0;
  without.localize.max_sigma_m = 1.0;
  MapperOptions with = without;
  with.localize.drift_per_m = 0.1;
  Placed a(corridor(), without), b(corridor(), with);
  ASSERT_TRUE(a.loaded && a.l.localized() && b.loaded && b.l.localized());
  for (int i = 0; i < 4; ++i) {
    a.drive.step(false);
    b.drive.step(false);
  }
  const int64_t corrections_a = a.l.stats().corrections, corrections_b = b.l.stats().corrections;
  a.drive.step(true, planar(0.3, 0, 0));
  b.drive.step(true, planar(0.3, 0, 0));
  EXPECT_EQ(a.l.stats().corrections, corrections_a);
  EXPECT_EQ(a.l.stats().refused_gate, 1);
  EXPECT_EQ(b.l.stats().corrections, corrections_b + 1);
  EXPECT_EQ(b.l.stats().refused_gate, 0);
}

// The corridor, and the same corridor on floor 1, 4 m above (nodes 10..19).
MapSnapshot twoFloors() {
  MapSnapshot map = corridor();
  map.floors.push_back({1, 4.0});
  for (int i = 0; i < 10; ++i) {
    StoredNode n = map.nodes[static_cast<size_t>(i)];
    n.node.id = 10 + i;
    n.node.floor = 1;
    n.world_T_body = SE3d(n.world_T_body.so3(), n.world_T_body.translation() + Vec3(0, 0, 4));
    map.nodes.push_back(n);
  }
  return map;
}

TEST(Localizer, VerticalMotionEndsLocalizationAtOnceAndStillnessWithoutARideRestoresIt) {
  Placed placed(twoFloors());
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  const SE3d before = l.pose().mean;
  // elevator-proc's first sign of a ride (its confirmed start comes seconds later).
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_VERTICAL_MOTION, 0.0, 0)).ok());
  EXPECT_FALSE(l.localized());
  EXPECT_EQ(l.stats().vertical_alarms, 1);
  EXPECT_FALSE(drive.step()) << "no registration request while the height is unobserved";
  // No ride followed: localized again, the height unchanged.
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_VERTICAL_STILL, 0.0, 0)).ok());
  EXPECT_TRUE(l.localized());
  EXPECT_NEAR(l.pose().mean.translation().z(), before.translation().z(), 1e-9);
  EXPECT_EQ(l.floor(), 0);
  EXPECT_EQ(l.stats().rides, 0);
}

TEST(Localizer, ARideAnnouncedByVerticalMotionEndsOnTheFloorItsHeightChangeReaches) {
  Placed placed(twoFloors());
  ASSERT_TRUE(placed.loaded && placed.l.localized());
  Localizer& l = placed.l;
  Drive& drive = placed.drive;
  // elevator-proc's heights are its own (here 10 m at the floor left): only the change counts.
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_VERTICAL_MOTION, 10.0, 0)).ok());
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_RIDE_START, 10.0, 0)).ok());
  // A stillness after the confirmed start belongs to no ride: it changes nothing.
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_VERTICAL_STILL, 10.0, 0)).ok());
  EXPECT_FALSE(l.localized());
  ASSERT_TRUE(l.onFloor(floorMsg(drive.now(), floor_t::EVENT_RIDE_END, 14.0, 1)).ok());
  EXPECT_TRUE(l.localized());
  EXPECT_EQ(l.floor(), 1);
  EXPECT_NEAR(l.pose().mean.translation().z(), 4.0, 1e-6);
  EXPECT_EQ(l.stats().rides, 1);
}

TEST(Localizer, AnEmptyMapIsRefused) {
  Localizer l(MapperOptions{});
  EXPECT_FALSE(l.load(MapSnapshot{}).ok());
}

}  // namespace
}  // namespace evermap::mapper
