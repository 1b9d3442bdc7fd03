// The Kinect-like depth sensor of the image-level simulator's RGB-D mode (depth_sensor.h), on
// exact depth images made by hand: a wall at 3.5 m and a box at 1 m in front of it.
#include <gtest/gtest.h>

#include <cmath>

#include "tools/sim/depth_sensor.h"

namespace evermap::sim {
namespace {

constexpr double kFx = 450.0;
constexpr int kW = 320, kH = 240;
constexpr int kBoxU0 = 140, kBoxU1 = 200, kBoxV0 = 60, kBoxV1 = 180;  // [u0, u1) x [v0, v1)

cv::Mat wallWithBox(float wall_m, float box_m) {
  cv::Mat truth(kH, kW, CV_32FC1, cv::Scalar(wall_m));
  truth(cv::Rect(kBoxU0, kBoxV0, kBoxU1 - kBoxU0, kBoxV1 - kBoxV0)).setTo(box_m);
  return truth;
}

TEST(DepthSensor, DepthIsTheTruthWithinTheKinectNoiseModel) {
  DepthSensorOptions o;
  o.dropout_fraction = 0.0;
  DepthSensor sensor(o, kFx, 1);
  for (const float z : {0.8f, 2.0f, 4.0f}) {
    const cv::Mat truth(kH, kW, CV_32FC1, cv::Scalar(z));
    cv::Mat depth;
    sensor.measure(truth, &depth);
    ASSERT_EQ(depth.type(), CV_16UC1);
    double sum = 0.0, sum2 = 0.0;
    for (int v = 0; v < kH; ++v) {
      for (int u = 0; u < kW; ++u) {
        const uint16_t m = depth.at<uint16_t>(v, u);
        ASSERT_NE(m, 0) << "no edge, no dropout: every pixel has depth";
        const double e = (m * o.unit_m - z) / sensor.sigma(z);
        sum += e;
        sum2 += e * e;
      }
    }
    const double n = kW * kH;
    EXPECT_NEAR(sum / n, 0.0, 0.03) << z;              // unbiased
    EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.03) << z;  // σ_z = 1.425e-3 z² (+ quantisation)
    EXPECT_NEAR(sensor.sigma(z), 1.425e-3 * z * z, 1e-12);
  }
}

TEST(DepthSensor, HolesAlongDepthEdgesAndTheProjectorShadowLeftOfNearObjects) {
  DepthSensorOptions o;
  o.dropout_fraction = 0.0;
  DepthSensor sensor(o, kFx, 2);
  const cv::Mat truth = wallWithBox(3.5f, 1.0f);
  cv::Mat depth;
  sensor.measure(truth, &depth);
  const int shadow =
      static_cast<int>(std::ceil(kFx * o.shadow_baseline_m * (1.0 / 1.0 - 1.0 / 3.5)));  // 25 px
  ASSERT_EQ(shadow, 25);
  const int v = (kBoxV0 + kBoxV1) / 2;
  // Left of the box: the shadow (25 px of the wall), and the edge's own holes on the box.
  for (int u = kBoxU0 - shadow; u < kBoxU0 + 1 + o.edge_hole_px; ++u) {
    EXPECT_EQ(depth.at<uint16_t>(v, u), 0) << "u " << u;
  }
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU0 - shadow - 1), 0);
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU0 + 2 + o.edge_hole_px), 0);
  // Right of the box: no shadow, the edge's holes only.
  for (int u = kBoxU1 - 1 - o.edge_hole_px; u <= kBoxU1 + o.edge_hole_px; ++u) {
    EXPECT_EQ(depth.at<uint16_t>(v, u), 0) << "u " << u;
  }
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU1 + o.edge_hole_px + 1), 0);
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU1 - 2 - o.edge_hole_px), 0);
  // Top and bottom edges: holes, no shadow.
  const int u = (kBoxU0 + kBoxU1) / 2;
  EXPECT_EQ(depth.at<uint16_t>(kBoxV0, u), 0);
  EXPECT_EQ(depth.at<uint16_t>(kBoxV0 - 1, u), 0);
  EXPECT_NE(depth.at<uint16_t>(kBoxV0 - 3, u), 0);
  EXPECT_EQ(depth.at<uint16_t>(kBoxV1, u), 0);
  EXPECT_NE(depth.at<uint16_t>(kBoxV1 + 2, u), 0);
  // Away from the box, everything has depth.
  EXPECT_EQ(cv::countNonZero(depth(cv::Rect(0, 0, 100, kH))), 100 * kH);
  EXPECT_EQ(cv::countNonZero(depth(cv::Rect(kBoxU0 + 3, kBoxV0 + 3, 50, 100))), 50 * 100);

  // No shadow with a zero baseline, no widening with edge_hole_px = 0.
  o.shadow_baseline_m = 0.0;
  o.edge_hole_px = 0;
  DepthSensor plain(o, kFx, 2);
  plain.measure(truth, &depth);
  EXPECT_EQ(depth.at<uint16_t>(v, kBoxU0 - 1), 0);
  EXPECT_EQ(depth.at<uint16_t>(v, kBoxU0), 0);
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU0 - 2), 0);
  EXPECT_NE(depth.at<uint16_t>(v, kBoxU0 + 1), 0);
}

TEST(DepthSensor, NothingOutsideTheRange) {
  DepthSensorOptions o;
  o.dropout_fraction = 0.0;
  DepthSensor sensor(o, kFx, 3);
  cv::Mat depth;
  for (const float z : {0.3f, 4.7f, 12.0f}) {  // nearer than min_range_m (0.5), beyond 4.5 m + 6σ
    sensor.measure(cv::Mat(kH, kW, CV_32FC1, cv::Scalar(z)), &depth);
    EXPECT_EQ(cv::countNonZero(depth), 0) << z;
  }
  // A ramp from 1 m to 8 m across the image: depth up to the range and none past it.
  cv::Mat ramp(kH, kW, CV_32FC1);
  for (int u = 0; u < kW; ++u) ramp.col(u).setTo(1.0 + 7.0 * u / (kW - 1));
  sensor.measure(ramp, &depth);
  for (int u = 0; u < kW; ++u) {
    const double z = ramp.at<float>(0, u);
    const int valid = cv::countNonZero(depth.col(u));
    if (z < o.max_range_m - 5 * sensor.sigma(z)) EXPECT_EQ(valid, kH) << z;
    if (z > o.max_range_m + 5 * sensor.sigma(z)) EXPECT_EQ(valid, 0) << z;
  }
  double max_m = 0.0;
  cv::minMaxLoc(depth, nullptr, &max_m);
  EXPECT_LE(max_m * o.unit_m, o.max_range_m + 1e-9);
  // Not finite or not positive: nothing there.
  cv::Mat none(kH, kW, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  none.row(5).setTo(0.0f);
  sensor.measure(none, &depth);
  EXPECT_EQ(cv::countNonZero(depth), 0);
}

TEST(DepthSensor, DropsTheConfiguredFractionAtRandom) {
  DepthSensorOptions o;
  o.dropout_fraction = 0.01;
  DepthSensor sensor(o, kFx, 4);
  int64_t dropped = 0, pixels = 0;
  cv::Mat depth;
  for (int k = 0; k < 20; ++k) {
    sensor.measure(cv::Mat(kH, kW, CV_32FC1, cv::Scalar(2.0f)), &depth);
    dropped += static_cast<int64_t>(depth.total()) - cv::countNonZero(depth);
    pixels += static_cast<int64_t>(depth.total());
  }
  const double rate = static_cast<double>(dropped) / static_cast<double>(pixels);
  EXPECT_NEAR(rate, 0.01, 0.001);
}

TEST(DepthSensor, SameSeedSameDepthOtherSeedOtherNoise) {
  const DepthSensorOptions o;
  const cv::Mat truth = wallWithBox(3.0f, 1.5f);
  cv::Mat a, b, c;
  DepthSensor s1(o, kFx, 7), s2(o, kFx, 7), s3(o, kFx, 8);
  s1.measure(truth, &a);
  s2.measure(truth, &b);
  s3.measure(truth, &c);
  EXPECT_EQ(cv::countNonZero(a != b), 0);
  EXPECT_GT(cv::countNonZero(a != c), kW * kH / 2);
}

TEST(DepthSensor, BadOptionsNameTheField) {
  for (const auto& [change, field] :
       std::vector<std::pair<void (*)(DepthSensorOptions&), std::string>>{
           {[](DepthSensorOptions& o) { o.max_range_m = 0.2; }, "min_range_m"},
           {[](DepthSensorOptions& o) { o.max_range_m = -1; }, "max_range_m"},
           {[](DepthSensorOptions& o) { o.unit_m = 1e-5; }, "unit_m"},
           {[](DepthSensorOptions& o) { o.noise_coefficient = -1; }, "noise_coefficient"},
           {[](DepthSensorOptions& o) { o.edge_hole_px = -1; }, "edge_hole_px"},
           {[](DepthSensorOptions& o) { o.dropout_fraction = 1.0; }, "dropout_fraction"},
           {[](DepthSensorOptions& o) { o.shadow_baseline_m = 2.0; }, "shadow_baseline_m"}}) {
    DepthSensorOptions o;
    change(o);
    const Status s = o.validate();
    ASSERT_FALSE(s) << field;
    EXPECT_EQ(s.error().message.rfind(field + ":", 0), 0u) << s.error().message;
  }
  EXPECT_TRUE(DepthSensorOptions{}.validate());
}

}  // namespace
}  // namespace evermap::sim
