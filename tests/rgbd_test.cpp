// RGB-D input: the frame message, TUM association and conversion, depth of corners, the
// equivalent stereo rig, and VoPipeline on good and bad RGB-D frames.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/pinhole.h"
#include "core/camera/rgbd_camera.h"
#include "core/features/rgbd_depth.h"
#include "core/messages/channels.h"
#include "core/messages/rgbd_convert.h"
#include "log_messages.h"
#include "scratch_dir.h"
#include "tools/datasets/to_lcm.h"
#include "tools/datasets/tum_rgbd.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap {
namespace {

using messages::RgbdFrame;

core::CameraCalibration smallCamera() {
  return core::pinholeCamera(320, 240, 260.0, 260.0, 159.5, 119.5);
}

// Blurred random texture (corners everywhere) and a fronto-parallel plane at depth_m.
RgbdFrame texturedFrame(int64_t utime, double depth_m, int shift_px = 0) {
  RgbdFrame f;
  f.utime = utime;
  f.depth_utime = utime + 300;
  f.camera = smallCamera();
  cv::Mat noise(f.camera.height, f.camera.width + 40, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(5, 5), 1.2);
  noise(cv::Rect(20 + shift_px, 0, f.camera.width, f.camera.height)).copyTo(f.gray);
  f.depth = cv::Mat(f.camera.height, f.camera.width, CV_16UC1,
                    cv::Scalar(std::round(depth_m / f.depth_scale_m)));
  return f;
}

std::vector<uint8_t> encode(const evermap::rgbd_image_t& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

TEST(RgbdMessage, RoundTripsRawPngAndZstdLosslessly) {
  RgbdFrame f = texturedFrame(1000, 1.5);
  f.depth.at<uint16_t>(3, 4) = 0;
  f.depth.at<uint16_t>(5, 6) = 65535;
  for (auto enc : {messages::ImageEncoding::kGray8, messages::ImageEncoding::kPng,
                   messages::ImageEncoding::kZstd}) {
    auto msg = messages::toMsg(f, enc);
    ASSERT_TRUE(msg.ok()) << msg.error().message;
    const auto bytes = encode(*msg);
    auto decoded = messages::decodeLcm<evermap::rgbd_image_t>(
        bytes.data(), static_cast<int64_t>(bytes.size()), "RGBD");
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    auto back = messages::fromMsg(*decoded);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->utime, 1000);
    EXPECT_EQ(back->depth_utime, 1300);
    EXPECT_EQ(cv::norm(back->gray, f.gray, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(back->depth, f.depth, cv::NORM_INF), 0.0);
    EXPECT_DOUBLE_EQ(back->depth_scale_m, f.depth_scale_m);
    EXPECT_DOUBLE_EQ(back->camera.fx, 260.0);
  }
}

TEST(RgbdMessage, RefusesDepthOfTheWrongSizeTypeScaleOrTime) {
  const RgbdFrame f = texturedFrame(1000, 1.5);
  auto good = messages::toMsg(f, messages::ImageEncoding::kPng);
  ASSERT_TRUE(good.ok());
  auto expectRefused = [](const evermap::rgbd_image_t& m, const std::string& words) {
    auto r = messages::fromMsg(m);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find(words), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  };
  evermap::rgbd_image_t m = *good;
  m.depth_width = 640;
  expectRefused(m, "depth 640x240, the gray image is 320x240");
  // An 8-bit PNG where 16-bit depth belongs.
  m = *good;
  cv::imencode(".png", f.gray, m.depth_data);
  m.depth_size = static_cast<int32_t>(m.depth_data.size());
  expectRefused(m, "8-bit");
  m = *good;
  m.depth_scale_m = 0.0;
  expectRefused(m, "depth_scale_m 0");
  m = *good;
  m.depth_scale_m = std::nan("");
  expectRefused(m, "depth_scale_m");
  m = *good;
  m.depth_utime = m.utime + 200000;  // 0.2 s: not one frame
  expectRefused(m, "not one frame");
  m = *good;
  m.depth_format = 7;
  expectRefused(m, "unknown depth_format 7");
  m = *good;
  m.depth_size -= 1;
  expectRefused(m, "depth_size");
  // toMsg refuses a depth of the wrong type or size, too.
  RgbdFrame bad = f;
  bad.depth.convertTo(bad.depth, CV_32FC1);
  EXPECT_FALSE(messages::toMsg(bad, messages::ImageEncoding::kPng).ok());
}

TEST(TumRgbd, AssociatesByTheClosestStampsFirstAsAssociatePy) {
  // a: 0, 30, 60, 90 ms; b: 5, 28, 95, 200 ms. 30-28 (2) first, then 0-5 and 90-95 (5);
  // 60 has nothing within 20 ms (28 is taken, 95 is 35 away); 200 nothing.
  const std::vector<int64_t> a = {0, 30000000, 60000000, 90000000};
  const std::vector<int64_t> b = {5000000, 28000000, 95000000, 200000000};
  const auto pairs = datasets::associateByTime(a, b, 20000000);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0], (std::pair<size_t, size_t>{0, 0}));
  EXPECT_EQ(pairs[1], (std::pair<size_t, size_t>{1, 1}));
  EXPECT_EQ(pairs[2], (std::pair<size_t, size_t>{3, 2}));
  // A stamp closer to a later one goes there: a 0 and 10, b 9 -> (10, 9).
  const auto p2 = datasets::associateByTime({0, 10000000}, {9000000}, 20000000);
  ASSERT_EQ(p2.size(), 1u);
  EXPECT_EQ(p2[0], (std::pair<size_t, size_t>{1, 0}));
}

TEST(TumRgbd, ConvertsAColorFolderAndCountsUnassociatedFrames) {
  testing::ScratchDir dir;
  std::filesystem::create_directories(dir / "rgb");
  std::filesystem::create_directories(dir / "depth");
  const RgbdFrame f = texturedFrame(0, 2.0);
  cv::Mat color;
  cv::cvtColor(f.gray, color, cv::COLOR_GRAY2BGR);
  std::string rgb = "# color\n", depth = "# depth\n";
  for (int i = 0; i < 3; ++i) {
    const std::string t = "100.0" + std::to_string(3 * i);  // 100.00, 100.03, 100.06 s
    cv::imwrite((dir / ("rgb/" + t + ".png")).string(), color);
    rgb += t + " rgb/" + t + ".png\n";
    if (i < 2) {  // the third color image has no depth
      cv::imwrite((dir / ("depth/" + t + ".png")).string(), f.depth);
      depth += t + " depth/" + t + ".png\n";
    }
  }
  dir.write("rgb.txt", rgb);
  dir.write("depth.txt", depth);
  dir.write("accelerometer.txt", "# acc\n100.01 0 9.8 0\n");
  datasets::TumToLcmOptions options;
  options.calibration = "ros-default";
  // 320x240 images against TUM's 640x480 calibration: the error names the file.
  auto wrong = datasets::convertTumRgbdToLcm(dir.path(), dir / "out.lcmlog", options);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("is 320x240, the calibration (ros-default) is 640x480"),
            std::string::npos)
      << wrong.error().message;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.lcmlog"));
  // At 640x480 it converts: 2 frames, 1 unassociated, the color made gray.
  for (int i = 0; i < 3; ++i) {
    const std::string t = "100.0" + std::to_string(3 * i);
    cv::Mat big_color, big_depth;
    cv::resize(color, big_color, cv::Size(640, 480));
    cv::resize(f.depth, big_depth, cv::Size(640, 480), 0, 0, cv::INTER_NEAREST);
    cv::imwrite((dir / ("rgb/" + t + ".png")).string(), big_color);
    if (i < 2) cv::imwrite((dir / ("depth/" + t + ".png")).string(), big_depth);
  }
  auto summary = datasets::convertTumRgbdToLcm(dir.path(), dir / "out.lcmlog", options);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  EXPECT_EQ(summary->messages.at(channels::kRgbd), 2);
  EXPECT_EQ(summary->messages.at(channels::kAccel), 1);
  EXPECT_EQ(summary->skipped_unpaired, 1);
  std::vector<evermap::rgbd_image_t> msgs;
  ASSERT_NO_FATAL_FAILURE(testing::readLogMessages(dir / "out.lcmlog", channels::kRgbd, &msgs));
  EXPECT_EQ(msgs.size(), 2u);
  for (const evermap::rgbd_image_t& m : msgs) {
    auto frame = messages::fromMsg(m);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    EXPECT_EQ(frame->gray.type(), CV_8UC1);
    EXPECT_NEAR(frame->metres(frame->depth.at<uint16_t>(100, 100)), 2.0, 1e-3);
  }
}

TEST(TumRgbd, RefusesADepthImageThatIsNot16Bit) {
  testing::ScratchDir dir;
  std::filesystem::create_directories(dir / "rgb");
  std::filesystem::create_directories(dir / "depth");
  cv::Mat gray(480, 640, CV_8UC1, cv::Scalar(100));
  cv::imwrite((dir / "rgb/1.png").string(), gray);
  cv::imwrite((dir / "depth/1.png").string(), gray);  // 8-bit
  dir.write("rgb.txt", "1.0 rgb/1.png\n");
  dir.write("depth.txt", "1.001 depth/1.png\n");
  auto r = datasets::convertTumRgbdToLcm(dir.path(), dir / "out.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("depth/1.png: depth must be 16-bit one-channel, is 8-bit"),
            std::string::npos)
      << r.error().message;
}

TEST(RgbdCamera, EquivalentStereoNoiseIsTheKinectModelAtEveryDepth) {
  auto cam = core::RgbdCamera::create(smallCamera(), {});
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  const core::StereoCamera& s = cam->stereo();
  for (double z : {0.5, 1.0, 2.5, 4.5}) {
    // Stereo: σ_z = z² σ_d / (f b) (frame_registration.cpp), with σ_d = 0.2 px.
    const double stereo_sigma = z * z * 0.2 / (s.fx() * s.baselineM());
    EXPECT_NEAR(stereo_sigma, cam->depthSigmaM(z), 1e-12);
    EXPECT_NEAR(cam->depthSigmaM(z), 1.425e-3 * z * z, 1e-12);
    // And through the rig's own back-projection covariance.
    const core::Mat3 C = s.backProjectionCovariance(
        Eigen::Vector3d(s.cx(), s.cy(), s.disparityFromDepth(z)), 0.0, 0.2);
    EXPECT_NEAR(std::sqrt(C(2, 2)), 1.425e-3 * z * z, 1e-9);
  }
}

TEST(RgbdDepth, ReadsDepthAndRefusesHolesEdgesAndRange) {
  auto cam = core::RgbdCamera::create(smallCamera(), {});
  ASSERT_TRUE(cam.ok());
  core::RgbdDepth depth({});
  const double scale = 0.0002;
  cv::Mat d(240, 320, CV_16UC1, cv::Scalar(10000));  // 2 m
  const float disp = depth.disparity(cam->stereo(), d, scale, 100.2f, 50.7f);
  ASSERT_TRUE(std::isfinite(disp));
  EXPECT_NEAR(cam->stereo().depthFromDisparity(disp), 2.0, 1e-6);
  // A hole next to the corner.
  d.at<uint16_t>(52, 101) = 0;
  EXPECT_TRUE(std::isnan(depth.disparity(cam->stereo(), d, scale, 100.0f, 51.0f)));
  // A depth edge: the right half of the window at 3 m.
  d.setTo(10000);
  d(cv::Rect(201, 0, 119, 240)).setTo(15000);
  EXPECT_TRUE(std::isnan(depth.disparity(cam->stereo(), d, scale, 200.0f, 100.0f)));
  EXPECT_TRUE(std::isfinite(depth.disparity(cam->stereo(), d, scale, 190.0f, 100.0f)));
  // Too near, and at the image border.
  d.setTo(1000);  // 0.2 m
  EXPECT_TRUE(std::isnan(depth.disparity(cam->stereo(), d, scale, 100.0f, 100.0f)));
  d.setTo(10000);
  EXPECT_TRUE(std::isnan(depth.disparity(cam->stereo(), d, scale, 1.0f, 100.0f)));
}

vo::VoPipeline makePipeline() {
  auto p = vo::VoPipeline::create({});
  EXPECT_TRUE(p.ok());
  return std::move(*p);
}

TEST(VoPipelineRgbd, TracksAShiftedTexturedPlane) {
  vo::VoPipeline pipeline = makePipeline();
  auto m0 = messages::toMsg(texturedFrame(1000000, 2.0), messages::ImageEncoding::kPng);
  auto m1 = messages::toMsg(texturedFrame(1033000, 2.0, 2), messages::ImageEncoding::kPng);
  ASSERT_TRUE(m0.ok() && m1.ok());
  const auto out0 = pipeline.handleRgbd(*m0).back();
  EXPECT_EQ(out0.result.status, vo::VoStatus::kNoData) << out0.result.message;
  ASSERT_TRUE(pipeline.rgbdCamera().has_value());
  const auto out1 = pipeline.handleRgbd(*m1).back();
  ASSERT_EQ(out1.result.status, vo::VoStatus::kOk) << out1.result.message;
  // The image moved 2 px left: the camera moved right by 2 px at 2 m (fx 260): ~1.5 cm in x,
  // or turned by the equivalent angle; either way a small motion, not a jump.
  EXPECT_LT(out1.result.ref_T_cur.translation().norm(), 0.05);
  EXPECT_GT(out1.result.num_inliers, 50);
  EXPECT_EQ(int{out1.delta.status}, int{evermap::vo_delta_t::STATUS_OK});
}

TEST(VoPipelineRgbd, AllZeroDepthIsTooFewFeaturesAndSaysWhy) {
  vo::VoPipeline pipeline = makePipeline();
  RgbdFrame f = texturedFrame(1000000, 2.0);
  f.depth.setTo(0);
  auto m = messages::toMsg(f, messages::ImageEncoding::kPng);
  ASSERT_TRUE(m.ok());
  const auto out = pipeline.handleRgbd(*m).back();
  EXPECT_EQ(out.result.status, vo::VoStatus::kInsufficientFeatures);
  EXPECT_NE(out.result.message.find("the depth image is all zero"), std::string::npos)
      << out.result.message;
  EXPECT_EQ(pipeline.stats().by_status[static_cast<size_t>(vo::VoStatus::kInsufficientFeatures)],
            1);
}

TEST(VoPipelineRgbd, BadDepthAndUnassociatedFramesAreCountedBadInput) {
  vo::VoPipeline pipeline = makePipeline();
  auto good = messages::toMsg(texturedFrame(1000000, 2.0), messages::ImageEncoding::kPng);
  ASSERT_TRUE(good.ok());
  evermap::rgbd_image_t wrong_size = *good;
  wrong_size.depth_height = 120;
  evermap::rgbd_image_t unassociated = *good;
  unassociated.depth_utime += 1000000;
  for (const auto* m : {&wrong_size, &unassociated}) {
    const auto out = pipeline.handleRgbd(*m).back();
    EXPECT_EQ(out.result.status, vo::VoStatus::kBadInput);
    EXPECT_EQ(out.result.message.rfind("RGBD: ", 0), 0u) << out.result.message;
  }
  EXPECT_EQ(pipeline.stats().by_status[static_cast<size_t>(vo::VoStatus::kBadInput)], 2);
  // Bytes that are not an rgbd_image_t: an error, counted as undecodable.
  const std::vector<uint8_t> junk(100, 0x42);
  EXPECT_FALSE(pipeline.handleRgbdBytes(junk.data(), static_cast<int64_t>(junk.size())).ok());
  EXPECT_EQ(pipeline.stats().undecodable, 1);
  // A good frame still works after them.
  EXPECT_EQ(pipeline.handleRgbd(*good).back().result.status, vo::VoStatus::kNoData);
}

}  // namespace
}  // namespace evermap
