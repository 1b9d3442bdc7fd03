// The image-level simulator's session: its sensors (IMU, ground truth, wheels), the LCM log
// it writes (stereo or RGB-D) and its configuration errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include <unistd.h>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgproc.hpp>

#include <evermap/rgbd_calib_t.hpp>

#include "core/camera/calibration.h"
#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/rgbd_convert.h"
#include "tests/test_data.h"
#include "tools/sim/image_session.h"
#include "tools/sim/render_world.h"
#include "tools/sim/stereo_renderer.h"

namespace evermap::sim {
namespace {

namespace fs = std::filesystem;

// A 3-floor building whose session starts with an elevator trip soon.
std::string smallConfig() {
  return "seed = 3\n"
         "building.floors = 3\nbuilding.main_floor = 1\nbuilding.main_cross_corridors = 3\n"
         "building.max_cross_corridors = 3\nbuilding.main_long_corridors = 1\n"
         "patrol.sessions = 1\npatrol.total_hours = 0.1\npatrol.other_floor_probability = 0.5\n"
         "camera.cx = 32\ncamera.cy = 24\ncamera.fx = 40\ncamera.fy = 40\n"
         "render.width = 64\nrender.height = 48\nrender.rate_hz = 2\nrender.posters = none\n"
         "imu.rate_hz = 200\nimu.accel_sigma_mps2 = 0\nimu.gyro_sigma_radps = "
         "0\nimu.gyro_bias_sigma_radps = 0\n"
         "imu.accel_bias_sigma_mps2 = 0\nground_truth.rate_hz = 20\nvo.passerby_rate_per_hour = "
         "0\n";
}

std::unique_ptr<ImageSimulator> makeSimulator(const std::string& text,
                                              const std::vector<std::string>& overrides = {}) {
  auto file = KeyValueFile::parse(text, "test.conf");
  EXPECT_TRUE(file);
  for (const std::string& o : overrides) EXPECT_TRUE(file->set(o, "test"));
  auto options = loadImageSimOptions(*file);
  EXPECT_TRUE(options) << options.error().message;
  auto sim = ImageSimulator::create(*options);
  EXPECT_TRUE(sim) << sim.error().message;
  return std::move(*sim);
}

// The streams besides the camera's in the log of a 3 s session: IMU, ground truth, wheels.
void expectMotionStreamsOfThreeSeconds(std::map<std::string, int>& seen) {
  EXPECT_EQ(seen[channels::kImu], 601);
  EXPECT_EQ(seen[channels::kGroundTruth], 61);
  EXPECT_EQ(seen[channels::kWheelOdom], 30);
}

TEST(ImageSession, NoiseFreeImuIntegratesToGroundTruthVelocityAndHeight) {
  auto probe = makeSimulator(smallConfig());
  ASSERT_FALSE(probe->session().rides.empty());
  const ElevatorRide ride = probe->session().rides.front();
  const double until_s =
      static_cast<double>(ride.end_utime + 10'000'000 - probe->startUtime()) * 1e-6;
  auto sim = makeSimulator(smallConfig(), {"render.max_duration_s = " + std::to_string(until_s)});
  VectorSink sink;
  auto summary = sim->run(sink);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_GE(summary->rides, 1);
  // Strapdown integration with the true attitude from t0 = 20 s before the ride.
  const Trajectory& traj = *sim->session().trajectory;
  const int64_t t0 = std::max(sim->startUtime(), ride.start_utime - 20'000'000);
  const BodyState s0 = traj.at(t0);
  Vec3 v = s0.velocity_world;
  double z = s0.world_T_body.translation().z();
  int64_t prev = -1;
  Vec3 a_prev = Vec3::Zero();
  double max_dv = 0.0, max_dz = 0.0, max_climb = 0.0;
  for (const auto& m : sink.messages) {
    if (m.channel != channels::kImu || m.utime < t0) continue;
    auto imu =
        messages::decodeLcm<imu_t>(m.data.data(), static_cast<int64_t>(m.data.size()), "IMU");
    ASSERT_TRUE(imu);
    const BodyState s = traj.at(m.utime);
    const Vec3 f(imu->linear_acceleration[0], imu->linear_acceleration[1],
                 imu->linear_acceleration[2]);
    const Vec3 a =
        s.world_T_body.so3() * f - Vec3(0, 0, sim->options().sim.sensors.imu.gravity_mps2);
    if (prev >= 0) {
      const double dt = static_cast<double>(m.utime - prev) * 1e-6;
      const Vec3 v_next = v + 0.5 * dt * (a + a_prev);
      z += 0.5 * dt * (v.z() + v_next.z());
      v = v_next;
    }
    prev = m.utime;
    a_prev = a;
    max_dv = std::max(max_dv, (v - s.velocity_world).norm());
    max_dz = std::max(max_dz, std::abs(z - s.world_T_body.translation().z()));
    max_climb = std::max(
        max_climb, std::abs(s.world_T_body.translation().z() - s0.world_T_body.translation().z()));
  }
  EXPECT_GT(max_climb, 2.0);  // the ride is in the window
  EXPECT_LT(max_dv, 0.02);
  EXPECT_LT(max_dz, 0.05);
}

TEST(ImageSession, LogRoundTripsThroughTheExistingReaders) {
  auto sim = makeSimulator(smallConfig(), {"render.max_duration_s = 3", "render.rate_hz = 10"});
  const fs::path log =
      fs::temp_directory_path() / ("sim_render_test_" + std::to_string(::getpid()) + ".lcmlog");
  auto summary = writeImageSessionLog(*sim, log);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->frames, 31);
  lcm::LogFile file(log.string(), "r");
  ASSERT_TRUE(file.good());
  std::map<std::string, int> seen;
  int64_t last = 0;
  int64_t last_calibration = -1;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    ++seen[e->channel];
    EXPECT_GE(e->timestamp, last);
    last = e->timestamp;
    if (e->channel == channels::kStereoCalib) {
      // Before the first pair, then every second (docs/contracts.md).
      last_calibration = e->timestamp;
      auto m = messages::decodeLcm<stereo_calib_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      auto calib = messages::fromMsg(*m);
      ASSERT_TRUE(calib) << calib.error().message;
      auto cam = core::rectifiedStereoCamera(*calib);
      ASSERT_TRUE(cam) << cam.error().message;
      EXPECT_NEAR(cam->baselineM(), 0.12, 1e-9);
    } else if (e->channel == channels::kStereo) {
      ASSERT_GE(last_calibration, 0) << "a pair before STEREO_CALIB";
      EXPECT_LE(e->timestamp - last_calibration,
                static_cast<int64_t>(channels::kCalibrationPeriodS * 1e6));
      auto m = messages::decodeLcm<stereo_image_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      auto frame = messages::fromMsg(*m);
      ASSERT_TRUE(frame) << frame.error().message;
      EXPECT_TRUE(frame->rectified);
      EXPECT_EQ(frame->left.cols, 64);
      EXPECT_EQ(frame->right.rows, 48);
    } else if (e->channel == channels::kGroundTruth) {
      auto m = messages::decodeLcm<pose_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      EXPECT_TRUE(messages::fromMsg(*m));
      EXPECT_EQ(m->session, 0);
    } else if (e->channel == channels::kImu) {
      auto m = messages::decodeLcm<imu_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      const imu::ImuSample s = imu::fromLcm(*m);
      EXPECT_TRUE(s.gyro_rad_s.allFinite() && s.accel_m_s2.allFinite());
    }
  }
  EXPECT_EQ(seen[channels::kStereoCalib], 4);  // 3 s of pairs (31 at 10 Hz): at 0, 1, 2 and 3 s
  EXPECT_EQ(seen[channels::kStereo], 31);
  expectMotionStreamsOfThreeSeconds(seen);
  fs::remove(log);
}

TEST(ImageSession, ElevatorRideShowsTheClosedCabAndChangesFloor) {
  auto sim = makeSimulator(smallConfig());
  ASSERT_FALSE(sim->session().rides.empty());
  const ElevatorRide ride = sim->session().rides.front();
  cv::Mat left, right;
  const FrameFacts before = sim->renderPair(ride.start_utime - 10'000'000, &left, &right);
  const FrameFacts during = sim->renderPair((ride.start_utime + ride.end_utime) / 2, &left, &right);
  const FrameFacts after = sim->renderPair(ride.end_utime + 10'000'000, &left, &right);
  EXPECT_TRUE(during.closed_cab);
  EXPECT_FALSE(before.closed_cab && after.closed_cab);
  EXPECT_EQ(before.floor, ride.floor_from);
  EXPECT_EQ(after.floor, ride.floor_to);
  EXPECT_NE(ride.floor_from, ride.floor_to);
}

TEST(ImageSession, PostersComeFromTheRealPhotographs) {
  EVERMAP_REQUIRE_DATA(data, "rtabmap-lcd-samples");
  Random rng(1);
  auto lib = makeTextureLibrary(TextureOptions{}, data / "samples", rng);
  ASSERT_TRUE(lib) << lib.error().message;
  EXPECT_EQ(lib->posters.size(), 40u);
}

TEST(ImageSession, RgbdModeWritesRgbdFramesWhoseDepthIsTheRayCastWithinTheKinectModel) {
  auto sim = makeSimulator(
      smallConfig(), {"render.max_duration_s = 3", "render.rate_hz = 10", "render.camera = rgbd",
                      "render.width = 320", "render.height = 240", "camera.fx = 225",
                      "camera.fy = 225", "camera.cx = 160", "camera.cy = 120"});
  const DepthSensorOptions& d = sim->options().render.depth;
  // The frames: depth within the noise model where the truth is in range and not at an edge,
  // none beyond the range, holes along depth edges.
  int64_t checked = 0, beyond = 0, beyond_valid = 0, edge_pixels = 0, edge_holes = 0;
  double chi2 = 0.0;
  for (int64_t t = sim->startUtime(); t <= sim->endUtime(); t += 500'000) {
    cv::Mat gray, depth, truth;
    sim->renderRgbd(t, &gray, &depth, &truth);
    ASSERT_EQ(depth.type(), CV_16UC1);
    ASSERT_EQ(depth.size(), gray.size());
    for (int v = 1; v + 1 < depth.rows; ++v) {
      for (int u = 1; u + 1 < depth.cols; ++u) {
        const double z = truth.at<float>(v, u);
        const uint16_t m = depth.at<uint16_t>(v, u);
        double spread = 0.0;
        for (const auto& [du, dv] :
             {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
          spread = std::max(spread, std::abs(truth.at<float>(v + dv, u + du) - z) / z);
        }
        if (spread > 0.2) {
          ++edge_pixels;
          edge_holes += m == 0;
          continue;
        }
        const double sigma = d.noise_coefficient * z * z;
        if (z > d.max_range_m + 5 * sigma) {
          ++beyond;
          beyond_valid += m != 0;
        } else if (m != 0) {
          const double e = (m * d.unit_m - z) / sigma;
          chi2 += e * e;
          ++checked;
          EXPECT_LT(std::abs(e), 6.0) << "pixel " << u << "," << v << " truth " << z;
        }
      }
    }
  }
  ASSERT_GT(checked, 10000);
  EXPECT_NEAR(chi2 / static_cast<double>(checked), 1.0, 0.1);  // σ_z = 1.425e-3 z²
  EXPECT_GT(beyond, 1000);  // corridors are longer than the Kinect's range
  EXPECT_EQ(beyond_valid, 0);
  ASSERT_GT(edge_pixels, 100);
  EXPECT_EQ(edge_holes, edge_pixels);

  // The log: RGBD_CALIB and RGBD in place of STEREO_CALIB and STEREO, readable by the RGB-D
  // readers.
  const fs::path log = fs::temp_directory_path() /
                       ("sim_render_rgbd_test_" + std::to_string(::getpid()) + ".lcmlog");
  auto summary = writeImageSessionLog(*sim, log);
  ASSERT_TRUE(summary) << summary.error().message;
  lcm::LogFile file(log.string(), "r");
  ASSERT_TRUE(file.good());
  std::map<std::string, int> seen;
  int64_t last_calibration = -1;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    ++seen[e->channel];
    if (e->channel == channels::kRgbdCalib) {
      last_calibration = e->timestamp;
      auto m = messages::decodeLcm<rgbd_calib_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      auto camera = messages::fromMsg(m->camera);
      ASSERT_TRUE(camera) << camera.error().message;
      EXPECT_NEAR(camera->fx, 225.0, 1e-12);
    } else if (e->channel == channels::kRgbd) {
      ASSERT_GE(last_calibration, 0) << "a frame before RGBD_CALIB";
      auto m = messages::decodeLcm<rgbd_image_t>(e->data, e->datalen, e->channel);
      ASSERT_TRUE(m);
      auto frame = messages::fromMsg(*m);
      ASSERT_TRUE(frame) << frame.error().message;
      EXPECT_EQ(frame->depth_utime, frame->utime);
      EXPECT_EQ(frame->depth_scale_m, d.unit_m);
      EXPECT_EQ(frame->depth.cols, 320);
      EXPECT_GT(cv::countNonZero(frame->depth), 0);
    }
  }
  EXPECT_EQ(seen[channels::kRgbd], 31);
  EXPECT_EQ(seen[channels::kRgbdCalib], 4);
  EXPECT_EQ(seen[channels::kStereo], 0);
  EXPECT_EQ(seen[channels::kStereoCalib], 0);
  expectMotionStreamsOfThreeSeconds(seen);
  fs::remove(log);
}

TEST(ImageSimOptions, BadConfigGivesAOneLineError) {
  for (const std::string bad :
       {"render.width = -3", "render.colour = 1", "render.encoding = jpeg", "lighting.gamma = 0",
        "camera.cx = 900", "building.floors = 0", "render.camera = mono", "rgbd.max_range_m = -1",
        "rgbd.unit_m = 0.00001", "rgbd.edge_hole_px = 40", "rgbd.dropout_fraction = 1.5"}) {
    auto file = KeyValueFile::parse(smallConfig(), "bad.conf");
    ASSERT_TRUE(file);
    ASSERT_TRUE(file->set(bad, "bad.conf:99"));
    auto options = loadImageSimOptions(*file);
    ASSERT_FALSE(options) << bad;
    const std::string& m = options.error().message;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_EQ(m.rfind("bad.conf:99: ", 0), 0u) << m;
  }
  Random rng(1);
  auto lib = makeTextureLibrary(TextureOptions{}, "/nonexistent/posters", rng);
  ASSERT_FALSE(lib);
  EXPECT_NE(lib.error().message.find("/nonexistent/posters"), std::string::npos);
}

}  // namespace
}  // namespace evermap::sim
