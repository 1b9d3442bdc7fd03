// core/camera StereoRectifier: the geometry on synthetic points, and the bar on the
// real EuRoC excerpt: after rectification, features matched between left and right lie on
// the same row (median vertical offset < 0.5 px).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/stereo_rectifier.h"
#include "test_data.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"

namespace evermap::core {
namespace {

namespace fs = std::filesystem;

StereoCalibration eurocCalibration(const fs::path& dir) {
  auto c = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                dir / "mav0/cam1/sensor.yaml");
  EXPECT_TRUE(c.ok()) << c.error().message;
  return *c;
}

// A raw rig like EuRoC's but synthetic, so the test runs without the data.
StereoCalibration syntheticRig() {
  StereoCalibration s;
  s.left.width = s.right.width = 752;
  s.left.height = s.right.height = 480;
  s.left.fx = 458.654;
  s.left.fy = 457.296;
  s.left.cx = 367.215;
  s.left.cy = 248.375;
  s.right.fx = 457.587;
  s.right.fy = 456.134;
  s.right.cx = 379.999;
  s.right.cy = 255.238;
  s.left.distortion_model = s.right.distortion_model = DistortionModel::kRadTan;
  s.left.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  s.right.distortion = {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05};
  s.left.body_T_cam = SE3d(SO3d::exp(Vec3(0.3, -0.1, 1.5)), Vec3(-0.02, -0.06, 0.01));
  // right_T_left: a small rotation and the right camera 0.11 m along +x.
  const SE3d right_T_left(SO3d::exp(Vec3(0.004, -0.012, 0.002)), Vec3(-0.11, 0.0004, -0.0006));
  s.right.body_T_cam = s.left.body_T_cam * right_T_left.inverse();
  return s;
}

// Raw pixel of a point in a raw camera frame (OpenCV's distortion model).
Eigen::Vector2d projectRaw(const CameraCalibration& c, const Vec3& p_cam) {
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  std::vector<cv::Point3d> pts = {cv::Point3d(p_cam.x(), p_cam.y(), p_cam.z())};
  std::vector<cv::Point2d> px;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, c.distortion, px);
  return Eigen::Vector2d(px[0].x, px[0].y);
}

TEST(StereoRectifier, RectifiedPointsShareARowAndGiveTheirDepth) {
  const StereoCalibration raw = syntheticRig();
  const auto rect = StereoRectifier::create(raw);
  ASSERT_TRUE(rect.ok()) << rect.error().message;
  const StereoCamera& cam = rect->camera();
  EXPECT_NEAR(cam.baselineM(), raw.right_T_left().translation().norm(), 1e-9);

  // Rectified left frame in the raw left frame.
  const SE3d cam0_T_rect0 =
      raw.left.body_T_cam.inverse() * rect->rectifiedCalibration().left.body_T_cam;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(-1.0, 1.0), y(-0.7, 0.7), z(1.0, 8.0);
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p_rect(x(rng) * 0.5, y(rng) * 0.5, z(rng));
    const Vec3 p_left = cam0_T_rect0 * p_rect;
    const Vec3 p_right = raw.right_T_left() * p_left;
    const auto expected = cam.project(p_rect);
    ASSERT_TRUE(expected.has_value());
    if (!cam.inImage(expected->x(), expected->y())) continue;
    const Eigen::Vector2d l =
        rect->rectifyPoint(StereoRectifier::Side::kLeft, projectRaw(raw.left, p_left));
    const Eigen::Vector2d r =
        rect->rectifyPoint(StereoRectifier::Side::kRight, projectRaw(raw.right, p_right));
    // Iterative undistortion converges to ~1e-4 px on this strong barrel distortion.
    EXPECT_NEAR(l.x(), expected->x(), 2e-3);
    EXPECT_NEAR(l.y(), expected->y(), 2e-3);
    EXPECT_NEAR(r.y(), l.y(), 2e-3);                  // the same row
    EXPECT_NEAR(l.x() - r.x(), expected->z(), 2e-3);  // disparity = fx b / z
    ++checked;
  }
  EXPECT_GT(checked, 100);
  // The rectified calibration describes the same pinhole pair.
  const auto again = rectifiedStereoCamera(rect->rectifiedCalibration());
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_NEAR(again->baselineM(), cam.baselineM(), 1e-12);
  EXPECT_NEAR(again->fx(), cam.fx(), 1e-12);
}

TEST(StereoRectifier, InconsistentCalibrationsAndImagesAreRefused) {
  StereoCalibration swapped = syntheticRig();
  std::swap(swapped.left, swapped.right);
  auto r = StereoRectifier::create(swapped);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("swapped"), std::string::npos) << r.error().message;

  StereoCalibration rectified = syntheticRig();
  rectified.rectified = true;
  r = StereoRectifier::create(rectified);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("already rectified"), std::string::npos);

  StereoCalibration bad = syntheticRig();
  bad.right.height = 400;
  r = StereoRectifier::create(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("image sizes differ"), std::string::npos);

  StereoRectifier::Options options;
  options.alpha = 2.0;
  r = StereoRectifier::create(syntheticRig(), options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("alpha"), std::string::npos);

  const auto ok = StereoRectifier::create(syntheticRig());
  ASSERT_TRUE(ok.ok());
  const cv::Mat good(480, 752, CV_8UC1, cv::Scalar(0));
  EXPECT_TRUE(ok->rectify(good, good).ok());
  auto out = ok->rectify(good, cv::Mat(480, 640, CV_8UC1));
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.error().message.find("right image is 640x480, the calibration says 752x480"),
            std::string::npos)
      << out.error().message;
  out = ok->rectify(cv::Mat(480, 752, CV_8UC3), good);
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.error().message.find("not 8-bit gray"), std::string::npos);
  EXPECT_FALSE(ok->rectify(cv::Mat(), good).ok());
}

// Vertical offsets |v_left - v_right| of ORB features matched between the two images of each
// pair. Matching uses appearance only, nothing that looks at the offset being measured:
// mutual nearest neighbours in Hamming distance and Lowe's ratio test (best < 0.8 x second
// best), which drops the ambiguous matches the Vicon room's repeated texture produces
// (without it about a third of the mutual matches are rows apart). FAST puts keypoints on
// integer pixels of each pyramid level, which would quantise the offsets to whole pixels, so
// each keypoint is refined to sub-pixel on the full-resolution image (cv::cornerSubPix).
std::vector<double> verticalOffsets(const std::vector<std::pair<cv::Mat, cv::Mat>>& pairs) {
  auto orb = cv::ORB::create(1000, 1.2f, 4);
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  const auto refine = [](const cv::Mat& image, const std::vector<cv::KeyPoint>& kps) {
    std::vector<cv::Point2f> pts;
    cv::KeyPoint::convert(kps, pts);
    if (!pts.empty()) {
      cv::cornerSubPix(image, pts, cv::Size(2, 2), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 30, 0.01));
    }
    return pts;
  };
  std::vector<double> out;
  for (const auto& [left, right] : pairs) {
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    orb->detectAndCompute(left, cv::noArray(), kl, dl);
    orb->detectAndCompute(right, cv::noArray(), kr, dr);
    if (dl.rows < 2 || dr.rows < 2) continue;
    const std::vector<cv::Point2f> pl = refine(left, kl), pr = refine(right, kr);
    std::vector<std::vector<cv::DMatch>> l2r, r2l;
    matcher.knnMatch(dl, dr, l2r, 2);
    matcher.knnMatch(dr, dl, r2l, 2);
    for (const auto& m : l2r) {
      if (m.size() < 2 || m[0].distance >= 0.8f * m[1].distance) continue;
      const auto& back = r2l[m[0].trainIdx];
      if (back.empty() || back[0].trainIdx != m[0].queryIdx) continue;  // not mutual
      out.push_back(std::abs(pl[m[0].queryIdx].y - pr[m[0].trainIdx].y));
    }
  }
  return out;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(StereoRectifier, EurocMatchedFeaturesLieOnTheSameRowAfterRectification) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const StereoCalibration raw = eurocCalibration(dir);
  const auto rect = StereoRectifier::create(raw);
  ASSERT_TRUE(rect.ok()) << rect.error().message;
  EXPECT_NEAR(rect->camera().baselineM(), 0.110, 0.002);  // EuRoC's stereo baseline
  std::printf("rectified EuRoC camera: %s\n", rect->camera().describe().c_str());

  const auto left_rows = datasets::readEurocImages(dir / "mav0/cam0/data.csv");
  ASSERT_TRUE(left_rows.ok()) << left_rows.error().message;
  std::vector<std::pair<cv::Mat, cv::Mat>> raw_pairs, rect_pairs;
  for (const datasets::ImageEntry& e : *left_rows) {
    const cv::Mat l =
        cv::imread((dir / "mav0/cam0/data" / e.filename).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat r =
        cv::imread((dir / "mav0/cam1/data" / e.filename).string(), cv::IMREAD_UNCHANGED);
    if (l.empty() || r.empty()) continue;
    const auto pair = rect->rectify(l, r);
    ASSERT_TRUE(pair.ok()) << pair.error().message;
    raw_pairs.emplace_back(l, r);
    rect_pairs.emplace_back(pair->left, pair->right);
  }
  ASSERT_EQ(rect_pairs.size(), 95u);

  const std::vector<double> raw_dv = verticalOffsets(raw_pairs);
  const std::vector<double> rect_dv = verticalOffsets(rect_pairs);
  ASSERT_GT(raw_dv.size(), 1000u);
  ASSERT_GT(rect_dv.size(), 1000u);
  const double raw_median = median(raw_dv);
  const double rect_median = median(rect_dv);
  std::printf(
      "EuRoC V1_01 excerpt, 95 pairs: median |v_left - v_right| raw %.3f px over %zu "
      "matches, rectified %.3f px over %zu matches\n",
      raw_median, raw_dv.size(), rect_median, rect_dv.size());
  EXPECT_LT(rect_median, 0.5);
  EXPECT_LT(rect_median, raw_median);
}

}  // namespace
}  // namespace evermap::core
