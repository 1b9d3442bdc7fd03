// evermap::imu::HeadingIntegrator: the gyro's heading about the world vertical, its bias
// estimated while the body is still (zero-rate updates), and AttitudeStream publishing it.

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "core/imu/lcm_convert.h"
#include "imu-proc/attitude_stream.h"
#include "imu-proc/heading_integrator.h"

namespace evermap::imu {
namespace {

constexpr double kG = 9.80665;
constexpr double kDeg = std::numbers::pi / 180.0;

// A robot on a level floor (or tilted by `tilt`): still, then turning in place by `turn_rad`
// at 0.8 rad/s, then still again. The gyro reads the body rate + bias + white noise.
struct Robot {
  Eigen::Vector3d bias{0.004, -0.003, 0.005};
  double noise = 0.002;  // rad/s per sample
  double rate_hz = 200.0;
  double still_s = 5.0, turn_rad = std::numbers::pi / 2, turn_rate = 0.8;
  core::SO3d tilt;  // fixed roll/pitch of the floor
  std::mt19937 rng{7};

  double yawRate(double t) const {
    const double t_turn = turn_rad / turn_rate;
    return t >= still_s && t < still_s + t_turn ? turn_rate : 0.0;
  }
  // Runs the integrator over [0, end_s]; returns the true yaw turned.
  double run(HeadingIntegrator* h, double end_s) {
    std::normal_distribution<double> n(0.0, noise);
    const int steps = static_cast<int>(end_s * rate_hz);
    double yaw = 0.0;
    for (int k = 0; k <= steps; ++k) {
      const double t = k / rate_hz;
      if (k > 0) yaw += yawRate(t - 0.5 / rate_hz) / rate_hz;
      ImuSample s;
      s.utime = static_cast<int64_t>(std::llround(t * 1e6));
      // Turning about the world vertical: body rate = world_R_bodyᵀ e_z r.
      const core::SO3d world_R_body = core::SO3d::fromRollPitchYaw(0, 0, yaw) * tilt;
      const Eigen::Vector3d w = world_R_body.inverse() * Eigen::Vector3d(0, 0, yawRate(t));
      s.gyro_rad_s = w + bias + Eigen::Vector3d(n(rng), n(rng), n(rng));
      s.accel_m_s2 = world_R_body.inverse() * Eigen::Vector3d(0, 0, kG);
      h->add(s, world_R_body);
    }
    return yaw;
  }
};

TEST(HeadingIntegrator, EstimatesTheGyroBiasWhileStillAndIntegratesATurn) {
  HeadingIntegrator h;
  Robot robot;
  const double yaw = robot.run(&h, 12.0);
  EXPECT_GE(h.counts().still_updates, 4);
  EXPECT_NEAR(h.bias().z(), robot.bias.z(), 5e-4);
  EXPECT_LT(h.rateSigmaRadS(), 1e-3);
  // A bias of 0.005 rad/s unremoved would be 3.4 degrees over the 12 s.
  EXPECT_NEAR(h.headingRad(), yaw, 0.3 * kDeg);
  EXPECT_NEAR(yaw, std::numbers::pi / 2, 0.01);
}

TEST(HeadingIntegrator, TurnsAboutTheWorldVerticalOnATiltedBody) {
  HeadingIntegrator h;
  Robot robot;
  robot.tilt = core::SO3d::fromRollPitchYaw(10 * kDeg, -8 * kDeg, 0.0);
  const double yaw = robot.run(&h, 12.0);
  EXPECT_NEAR(h.headingRad(), yaw, 0.3 * kDeg);
}

TEST(HeadingIntegrator, ASteadySlowTurnIsNotTakenForABias) {
  // Turning at 0.2 rad/s for 20 s without a stop: the rate is steady (spread below the
  // stillness limit) but far from any bias: no zero-rate update, the turn is integrated.
  HeadingIntegrator h;
  Robot robot;
  robot.still_s = 0.0;
  robot.turn_rate = 0.2;
  robot.turn_rad = 4.0;
  const double yaw = robot.run(&h, 20.0);
  EXPECT_EQ(h.counts().still_updates, 0);
  // Unestimated bias: 0.005 rad/s x 20 s.
  EXPECT_NEAR(h.headingRad(), yaw + 20.0 * robot.bias.z(), 0.3 * kDeg);
  EXPECT_NEAR(h.rateSigmaRadS(), HeadingOptions{}.initial_bias_sigma_rad_s, 1e-3);
}

TEST(HeadingIntegrator, RefusesInvalidOptions) {
  HeadingOptions o;
  o.still_window_s = 0.0;
  EXPECT_FALSE(o.validate());
  o = HeadingOptions{};
  o.noise_density = std::nan("");
  EXPECT_FALSE(o.validate());
  EXPECT_TRUE(HeadingOptions{}.validate());
}

TEST(AttitudeStream, PublishesTheGyroHeadingWithTheAttitude) {
  AttitudeStream stream(AttitudeFilterOptions{}, 50.0);
  Robot robot;
  std::normal_distribution<double> n(0.0, robot.noise);
  double yaw = 0.0;
  std::optional<attitude_t> first, last;
  int published = 0;
  for (int k = 0; k <= 12 * 200; ++k) {
    const double t = k / 200.0;
    if (k > 0) yaw += robot.yawRate(t - 0.0025) / 200.0;
    ImuSample s;
    s.utime = 1'000'000 + k * 5000;
    s.gyro_rad_s = Eigen::Vector3d(0, 0, robot.yawRate(t)) + robot.bias +
                   Eigen::Vector3d(n(robot.rng), n(robot.rng), n(robot.rng));
    s.accel_m_s2 = Eigen::Vector3d(0, 0, kG);
    if (auto m = stream.add(toLcm(s))) {
      if (!first) first = m;
      last = m;
      ++published;
    }
  }
  ASSERT_TRUE(last.has_value());
  EXPECT_NEAR(published, 12 * 50, 55);  // the filter's start-up window publishes nothing
  EXPECT_EQ(last->heading_valid, 1);
  EXPECT_NEAR(last->heading_rad, yaw, 0.3 * kDeg);
  EXPECT_GT(last->heading_rate_sigma_rad_s, 0.0);
  EXPECT_LT(last->heading_rate_sigma_rad_s, 1e-3);
  // One integration, from a sample before the first message on: one epoch.
  EXPECT_GT(first->heading_epoch, 0);
  EXPECT_LE(first->heading_epoch, first->utime);
  EXPECT_EQ(last->heading_epoch, first->heading_epoch);
}

TEST(HeadingIntegrator, AGapItCannotIntegrateStartsANewEpoch) {
  // Headings of one epoch differ by the rotation between them (a consumer may bridge lost
  // messages); a gap in the IMU itself is a rotation nobody measured: a new epoch.
  HeadingIntegrator h;
  ImuSample s;
  s.accel_m_s2 = Eigen::Vector3d(0, 0, kG);
  EXPECT_EQ(h.epoch(), 0);
  for (int64_t t = 2'000'000; t <= 3'000'000; t += 5000) {
    s.utime = t;
    h.add(s, core::SO3d());
  }
  EXPECT_EQ(h.epoch(), 2'000'000);
  s.utime = 3'000'000 + static_cast<int64_t>(2e6 * HeadingOptions{}.max_gap_s);
  h.add(s, core::SO3d());
  EXPECT_EQ(h.counts().gaps, 1);
  EXPECT_EQ(h.epoch(), s.utime);
}

}  // namespace
}  // namespace evermap::imu
