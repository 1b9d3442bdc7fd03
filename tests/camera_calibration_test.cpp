// core/camera calibration structs and the EuRoC sensor.yaml reader: the real files read
// correctly, and every inconsistent calibration is refused with a message naming the input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>

#include "core/camera/calibration.h"
#include "core/camera/pinhole.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/euroc_calibration.h"

namespace evermap::core {
namespace {

namespace fs = std::filesystem;

CameraCalibration pinhole() { return pinholeCamera(640, 480, 400.0, 400.0, 320.0, 240.0); }

// A rectified pair with baseline b: the right camera at +b along x of the left.
StereoCalibration rectifiedPair(double b) { return core::rectifiedPair(pinhole(), b); }

void expectRefused(const Status& s, const std::string& needle) {
  ASSERT_FALSE(s.ok()) << "accepted, wanted an error containing: " << needle;
  EXPECT_NE(s.error().message.find(needle), std::string::npos)
      << "got: " << s.error().message << "\nwanted: " << needle;
}

TEST(CameraCalibration, EachInconsistentFieldIsRefusedByName) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(pinhole().validate("cam").ok());
  // Each case: the pinhole changed in one way, and the error it must give.
  const auto refused = [](auto change, const std::string& needle) {
    CameraCalibration c = pinhole();
    change(c);
    expectRefused(c.validate("cam0"), needle);
  };
  using Cam = CameraCalibration;
  refused([](Cam& c) { c.fx = 0.0; }, "cam0: focal length fx = 0");
  refused([nan](Cam& c) { c.fy = nan; }, "focal length fy = nan");
  refused([](Cam& c) { c.fx = -458.0; }, "fx = -458");
  refused([](Cam& c) { c.width = 0; }, "image size 0x480 must be positive");
  refused([](Cam& c) { c.height = -480; }, "image size 640x-480");
  refused([](Cam& c) { c.cx = 640.0; }, "principal point (640, 240) is outside the 640x480 image");
  refused([](Cam& c) { c.cy = -1.0; }, "principal point (320, -1) is outside");
  auto c = pinhole();
  c.distortion_model = DistortionModel::kRadTan;
  c.distortion = {0.1, 0.2};
  expectRefused(c.validate("cam0"), "needs 4 or 5 coefficients");
  c.distortion = {0.1, nan, 0.0, 0.0};
  expectRefused(c.validate("cam0"), "non-finite distortion");
  c = pinhole();
  c.distortion = {0.1};
  expectRefused(c.validate("cam0"), "distortion model none with 1 coefficients");
}

TEST(StereoCalibration, ConsistentPairsAreAccepted) {
  EXPECT_TRUE(rectifiedPair(0.537).validate().ok());
  const auto cam = rectifiedStereoCamera(rectifiedPair(0.537));
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_NEAR(cam->baselineM(), 0.537, 1e-12);
  // An unrectified pair may be rotated and distorted.
  StereoCalibration raw = rectifiedPair(0.11);
  raw.rectified = false;
  raw.right.body_T_cam = SE3d(SO3d::exp(Vec3(0.01, -0.02, 0.005)), Vec3(0.11, 0.002, -0.001));
  raw.right.distortion_model = DistortionModel::kRadTan;
  raw.right.distortion = {-0.28, 0.07, 0.0002, 0.00002};
  EXPECT_TRUE(raw.validate().ok());
}

TEST(StereoCalibration, ImageSizeMismatchBetweenLeftAndRightIsRefused) {
  StereoCalibration s = rectifiedPair(0.1);
  s.right.width = 752;
  s.right.cx = 376.0;
  expectRefused(s.validate("rig.yaml"),
                "rig.yaml: image sizes differ: left 640x480, right 752x480");
}

TEST(StereoCalibration, ZeroBaselineIsRefused) {
  expectRefused(rectifiedPair(0.0).validate(), "baseline is 0 m");
  StereoCalibration raw = rectifiedPair(0.0);
  raw.rectified = false;
  expectRefused(raw.validate(), "baseline is 0 m");
}

TEST(StereoCalibration, RightCameraOnTheLeftIsRefusedAsSwapped) {
  expectRefused(rectifiedPair(-0.5).validate(), "left and right swapped?");
}

TEST(StereoCalibration, RectifiedPairsMustBeUndistortedAlignedAndShareIntrinsics) {
  StereoCalibration s = rectifiedPair(0.5);
  s.left.distortion_model = DistortionModel::kRadTan;
  s.left.distortion = {0.1, 0.0, 0.0, 0.0};
  expectRefused(s.validate(), "marked rectified but a camera has a distortion model");
  s = rectifiedPair(0.5);
  s.right.fx = 401.0;
  expectRefused(s.validate(), "marked rectified but the intrinsics differ");
  s = rectifiedPair(0.5);
  s.right.fy = 399.0;
  expectRefused(s.validate(), "marked rectified but the intrinsics differ");
  s = rectifiedPair(0.5);
  s.right.cy = 240.8;
  expectRefused(s.validate(),
                "marked rectified but the intrinsics differ: left fx fy cy = 400 400 240, right "
                "400 400 240.8");
  EXPECT_FALSE(rectifiedStereoCamera(s).ok());
  s = rectifiedPair(0.5);
  s.right.body_T_cam = SE3d(SO3d::exp(Vec3(0.0, 0.01, 0.0)), Vec3(0.5, 0.0, 0.0));
  expectRefused(s.validate(), "marked rectified but the cameras are rotated");
  s = rectifiedPair(0.5);
  s.right.body_T_cam = SE3d(SO3d(), Vec3(0.5, 0.05, 0.0));
  expectRefused(s.validate(), "the baseline is not along x");
  s = rectifiedPair(0.5);
  s.rectified = false;
  EXPECT_FALSE(rectifiedStereoCamera(s).ok());
}

TEST(StereoCalibration, ARectifiedPairsDifferingCxIsItsDisparityOffset) {
  StereoCalibration s = rectifiedPair(0.537);
  s.right.cx = 320.8;
  ASSERT_TRUE(s.validate().ok()) << s.validate().error().message;
  const auto cam = rectifiedStereoCamera(s);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_EQ(cam->disparityOffsetPx(), 320.8 - 320.0);
  EXPECT_EQ(cam->cx(), 320.0);  // the left camera's: pixels are in the left image
  s.right.cx = 319.5;
  EXPECT_EQ(rectifiedStereoCamera(s)->disparityOffsetPx(), -0.5);
  EXPECT_EQ(rectifiedStereoCamera(rectifiedPair(0.537))->disparityOffsetPx(), 0.0);
}

TEST(StereoCalibration, ADisparityOffsetBeyondAQuarterOfTheWidthIsRefused) {
  StereoCalibration s = rectifiedPair(0.5);
  s.right.cx = 320.0 + 160.0;  // 640 / 4: the largest accepted
  EXPECT_TRUE(rectifiedStereoCamera(s).ok());
  s.right.cx = 320.0 + 160.5;
  expectRefused(s.validate("rig"),
                "rig: marked rectified but the principal points differ by right cx - left cx = "
                "160.5 px, beyond a quarter of the 640 px width");
  EXPECT_FALSE(rectifiedStereoCamera(s).ok());
  s.right.cx = 100.0;
  expectRefused(s.validate(), "right cx - left cx = -220 px");
}

TEST(StereoCalibration, WithDisparityOffsetSetsTheRightCameraOfARectifiedPairOnly) {
  const StereoCalibration s = rectifiedPair(0.537);
  const auto with = withDisparityOffset(s, 0.8);
  ASSERT_TRUE(with.ok()) << with.error().message;
  EXPECT_EQ(with->right.cx, 320.0 + 0.8);
  EXPECT_EQ(with->left.cx, 320.0);
  EXPECT_NEAR(rectifiedStereoCamera(*with)->disparityOffsetPx(), 0.8, 1e-12);
  // Replaced, not added; 0 gives the calibration back unchanged.
  EXPECT_EQ(withDisparityOffset(*with, 0.3)->right.cx, 320.0 + 0.3);
  EXPECT_EQ(withDisparityOffset(*with, 0.0)->right.cx, 320.0);
  expectRefused(withDisparityOffset(s, 200.0).error(), "beyond a quarter of the 640 px width");
  expectRefused(withDisparityOffset(s, std::nan("")).error(), "disparity offset nan px");
  StereoCalibration raw = s;
  raw.rectified = false;
  expectRefused(withDisparityOffset(raw, 0.8).error(), "the stereo calibration is not rectified");
}

// ---- EuRoC sensor.yaml ----

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Writes `text` to `name` in the test's scratch folder.
fs::path writeTemp(const testing::ScratchDir& dir, const std::string& name,
                   const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(EurocCalibration, RealSensorYamlFilesAreReadExactly) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const auto c = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                      dir / "mav0/cam1/sensor.yaml");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_FALSE(c->rectified);
  EXPECT_EQ(c->left.width, 752);
  EXPECT_EQ(c->left.height, 480);
  EXPECT_DOUBLE_EQ(c->left.fx, 458.654);
  EXPECT_DOUBLE_EQ(c->left.fy, 457.296);
  EXPECT_DOUBLE_EQ(c->left.cx, 367.215);
  EXPECT_DOUBLE_EQ(c->left.cy, 248.375);
  EXPECT_DOUBLE_EQ(c->right.cx, 379.999);
  ASSERT_EQ(c->left.distortion.size(), 4u);
  EXPECT_EQ(c->left.distortion_model, DistortionModel::kRadTan);
  EXPECT_DOUBLE_EQ(c->left.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(c->right.distortion[3], -3.55590700e-05);
  EXPECT_NEAR(c->left.body_T_cam.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(c->left.body_T_cam.rotationMatrix()(0, 1), -0.999880929698, 1e-9);
  // The known EuRoC stereo extrinsics: cam1 about 0.110 m along +x of cam0.
  const SE3d r_T_l = c->right_T_left();
  EXPECT_NEAR(r_T_l.translation().norm(), 0.1101, 5e-4);
  EXPECT_NEAR(r_T_l.translation().x(), -0.1101, 1e-3);
  EXPECT_NEAR(rotationAngle(r_T_l.so3()), 0.0143, 1e-3);  // the two cameras differ by 0.8 deg
}

TEST(EurocCalibration, BrokenFilesAreRefusedNamingTheFileAndField) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const testing::ScratchDir scratch;
  const std::string good = readText(dir / "mav0/cam0/sensor.yaml");
  const auto refuse = [](const fs::path& p, const std::string& needle) {
    const auto c = datasets::readEurocCameraYaml(p);
    ASSERT_FALSE(c.ok()) << p << " accepted";
    EXPECT_NE(c.error().message.find(p.string()), std::string::npos) << c.error().message;
    EXPECT_NE(c.error().message.find(needle), std::string::npos)
        << "got: " << c.error().message << "\nwanted: " << needle;
  };
  refuse("/nonexistent/cam0/sensor.yaml", "cannot open");
  refuse(writeTemp(scratch, "garbage.yaml", "%YAML:1.0\nintrinsics: [1, 2\n  : ]]]\n"), "");
  // The good file with one field broken: what is replaced, by what, and the refusal.
  const struct {
    const char* file;
    const char* pattern;
    const char* replacement;
    const char* refusal;
  } broken[] = {
      {"no_intrinsics.yaml", "intrinsics:.*", "", "intrinsics must be 4 numbers"},
      {"three_intrinsics.yaml", "intrinsics: \\[[^\\]]*\\]",
       "intrinsics: [458.654, 457.296, 367.215]", "intrinsics must be 4 numbers"},
      {"zero_fx.yaml", "458\\.654", "0.0", "focal length fx = 0"},
      {"nan_fy.yaml", "457\\.296", ".nan", "focal length fy = nan"},
      {"pp_outside.yaml", "367\\.215", "900.0",
       "principal point (900, 248.375) is outside the 752x480 image"},
      {"zero_size.yaml", "resolution: \\[752, 480\\]", "resolution: [0, 480]",
       "image size 0x480 must be positive"},
      {"fisheye.yaml", "radial-tangential", "equidistant",
       "distortion_model \"equidistant\" is not supported"},
      {"bad_tbs.yaml", "0\\.0148655429818", "0.5", "T_BS is not a rigid transform"},
  };
  for (const auto& b : broken) {
    refuse(
        writeTemp(scratch, b.file, std::regex_replace(good, std::regex(b.pattern), b.replacement)),
        b.refusal);
  }
}

TEST(EurocCalibration, InconsistentPairsAreRefused) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const testing::ScratchDir scratch;
  const fs::path cam0 = dir / "mav0/cam0/sensor.yaml";
  const std::string right = readText(dir / "mav0/cam1/sensor.yaml");
  // Same file twice: the cameras coincide.
  auto c = datasets::readEurocStereoCalibration(cam0, cam0);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("baseline is 0 m"), std::string::npos) << c.error().message;
  // A right camera of another resolution.
  const fs::path small =
      writeTemp(scratch, "cam1_small.yaml",
                std::regex_replace(right, std::regex("resolution: \\[752, 480\\]"),
                                   "resolution: [640, 480]"));
  c = datasets::readEurocStereoCalibration(cam0, small);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("image sizes differ: left 752x480, right 640x480"),
            std::string::npos)
      << c.error().message;
  EXPECT_NE(c.error().message.find("cam1_small.yaml"), std::string::npos) << c.error().message;
}

}  // namespace
}  // namespace evermap::core
