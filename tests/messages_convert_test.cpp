// core/messages/convert: round trips through the LCM wire format, and refusal (never a crash)
// of every kind of malformed message, including random corruption of encoded bytes.
#include <gtest/gtest.h>

#include "image_test_util.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/imu/lcm_convert.h"
#include "core/imu/sample_gate.h"
#include "core/messages/convert.h"
#include "core/messages/pose_fields.h"
#include "scratch_dir.h"

namespace evermap::messages {
namespace {

namespace fs = std::filesystem;
const double kNan = std::numeric_limits<double>::quiet_NaN();

template <typename Msg>
std::vector<uint8_t> encode(const Msg& msg) {
  std::vector<uint8_t> bytes(msg.getEncodedSize());
  EXPECT_EQ(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

template <typename Msg>
Msg throughWire(const Msg& msg) {
  const auto bytes = encode(msg);
  auto back = decodeLcm<Msg>(bytes.data(), static_cast<int64_t>(bytes.size()), "TEST");
  EXPECT_TRUE(back.ok()) << back.error().message;
  return *back;
}

// A gray image with structure everywhere (so PNG has something to compress and a swapped
// row or column shows).
cv::Mat testImage(int w, int h, int seed) {
  cv::Mat m(h, w, CV_8UC1);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c)
      m.at<uint8_t>(r, c) = static_cast<uint8_t>((r * 7 + c * 3 + seed) ^ (r * c));
  }
  return m;
}

using evermap::testing::expectError;
using evermap::testing::sameImage;

core::CameraCalibration eurocLeft() {
  core::CameraCalibration c;
  c.width = 752;
  c.height = 480;
  c.fx = 458.654;
  c.fy = 457.296;
  c.cx = 367.215;
  c.cy = 248.375;
  c.distortion_model = core::DistortionModel::kRadTan;
  c.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  c.body_T_cam = core::SE3d(core::SO3d::exp(core::Vec3(0.1, -1.5, 1.6)),
                            core::Vec3(-0.0216401454975, -0.064676986768, 0.00981073058949));
  return c;
}

TEST(Utime, NanosecondsRoundToTheNearestMicrosecond) {
  EXPECT_EQ(utimeFromNs(1403715273262142976LL), 1403715273262143LL);
  EXPECT_EQ(utimeFromNs(1403715273312143104LL), 1403715273312143LL);
  EXPECT_EQ(utimeFromNs(0), 0);
  EXPECT_EQ(utimeFromNs(1499), 1);
  EXPECT_EQ(utimeFromNs(1500), 2);
  EXPECT_EQ(utimeFromNs(-1499), -1);
  EXPECT_EQ(utimeFromNs(-1501), -2);
  EXPECT_EQ(nsFromUtime(utimeFromNs(123456789000LL)), 123456789000LL);
}

TEST(ImageMsg, Gray8PngAndZstdRoundTripPixelExactThroughTheWire) {
  const cv::Mat image = testImage(75, 48, 1);
  for (ImageEncoding e : {ImageEncoding::kGray8, ImageEncoding::kPng, ImageEncoding::kZstd}) {
    auto msg = toMsg(image, 42, e);
    ASSERT_TRUE(msg.ok()) << msg.error().message;
    EXPECT_EQ(msg->width, 75);
    EXPECT_EQ(msg->height, 48);
    const int32_t format = e == ImageEncoding::kPng    ? int32_t{evermap::image_t::FORMAT_PNG}
                           : e == ImageEncoding::kZstd ? int32_t{evermap::image_t::FORMAT_ZSTD}
                                                       : int32_t{evermap::image_t::FORMAT_GRAY8};
    EXPECT_EQ(msg->pixelformat, format);
    const auto back = fromMsg(throughWire(*msg));
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(sameImage(*back, image)) << toString(e);
  }
  // A non-contiguous view (a region of a larger image) is copied row by row.
  const cv::Mat big = testImage(200, 100, 2);
  const cv::Mat roi = big(cv::Rect(10, 20, 64, 30));
  const auto back = fromMsg(*toMsg(roi, 1, ImageEncoding::kGray8));
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(sameImage(*back, roi));
}

TEST(ImageMsg, AGray8MessageWithAWiderStrideIsRead) {
  const cv::Mat image = testImage(10, 4, 3);
  evermap::image_t msg = *toMsg(image, 7, ImageEncoding::kGray8);
  // Re-pack with 16 bytes per row.
  std::vector<uint8_t> padded(16 * 4, 0xEE);
  for (int r = 0; r < 4; ++r) std::copy_n(image.ptr(r), 10, padded.begin() + 16 * r);
  msg.row_stride = 16;
  msg.data = padded;
  msg.size = static_cast<int32_t>(padded.size());
  const auto back = fromMsg(msg);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(sameImage(*back, image));
}

TEST(ImageMsg, MalformedImagesAreRefusedWithTheReason) {
  const cv::Mat image = testImage(32, 16, 4);
  const evermap::image_t gray = *toMsg(image, 5, ImageEncoding::kGray8);
  const evermap::image_t png = *toMsg(image, 5, ImageEncoding::kPng);

  // Each case: the message changed in one way, and the error it must give.
  const auto refused = [](const evermap::image_t& good, auto change, const std::string& needle) {
    evermap::image_t m = good;
    change(m);
    expectError(fromMsg(m), needle);
  };
  using Image = evermap::image_t;
  refused(
      gray, [](Image& m) { m.width = 0; }, "size 0x16 is not in 1..16384");
  refused(
      gray, [](Image& m) { m.height = 1 << 20; }, "is not in 1..16384");
  refused(
      gray, [](Image& m) { m.size = 100; }, "size field 100 but 512 data bytes");
  refused(
      gray, [](Image& m) { m.row_stride = 31; }, "row_stride 31 is less than width 32");
  refused(
      gray, [](Image& m) { m.height = 17; }, "needs 544 bytes, has 512");
  refused(
      gray, [](Image& m) { m.pixelformat = 99; }, "unknown pixelformat 99");
  refused(
      png, [](Image& m) { m.width = 33; }, "the PNG is 32x16, the message says 33x16");
  refused(
      png, [](Image& m) { m.data[0] = 'X'; }, "the data is not a PNG");
  refused(
      png,
      [](Image& m) {
        m.data.resize(m.data.size() / 2);  // a truncated PNG
        m.size = static_cast<int32_t>(m.data.size());
      },
      "corrupt or unsupported image data");
  refused(
      png, [](Image& m) { m.row_stride = 32; }, "row_stride must be 0 for PNG");
  // A colour PNG is not a gray image.
  cv::Mat colour(16, 32, CV_8UC3, cv::Scalar(1, 2, 3));
  std::vector<uint8_t> bytes;
  cv::imencode(".png", colour, bytes);
  refused(
      png,
      [&bytes](Image& m) {
        m.data = bytes;
        m.size = static_cast<int32_t>(bytes.size());
      },
      "not an 8-bit gray image (3 channels");
  // And the sender side refuses what it cannot describe.
  expectError(toMsg(colour, 1, ImageEncoding::kPng), "must be a non-empty 8-bit gray image");
  expectError(toMsg(cv::Mat(), 1, ImageEncoding::kGray8), "must be a non-empty 8-bit gray image");
}

TEST(ImageMsg, ImageFilesAreCarriedOrRefusedNamingTheFile) {
  const testing::ScratchDir scratch;
  const fs::path dir = scratch.path();
  const cv::Mat image = testImage(40, 30, 5);
  cv::imwrite((dir / "a.png").string(), image);
  std::vector<uint8_t> file_bytes;
  cv::imencode(".png", image, file_bytes);

  auto png = imageMsgFromFile(dir / "a.png", 9, ImageEncoding::kPng);
  ASSERT_TRUE(png.ok()) << png.error().message;
  EXPECT_EQ(png->width, 40);
  EXPECT_EQ(png->height, 30);
  EXPECT_EQ(png->utime, 9);
  EXPECT_TRUE(sameImage(*fromMsg(*png), image));
  auto raw = imageMsgFromFile(dir / "a.png", 9, ImageEncoding::kGray8);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->size, 40 * 30);
  EXPECT_TRUE(sameImage(*fromMsg(*raw), image));

  std::ofstream(dir / "corrupt.png") << "\x89PNG\r\n\x1a\n this is not a png body";
  expectError(imageMsgFromFile(dir / "corrupt.png", 1, ImageEncoding::kPng),
              (dir / "corrupt.png").string() + ": corrupt or unsupported image data");
  std::ofstream(dir / "empty.png").close();
  expectError(imageMsgFromFile(dir / "empty.png", 1, ImageEncoding::kPng),
              (dir / "empty.png").string() + ": empty file");
  expectError(imageMsgFromFile(dir / "missing.png", 1, ImageEncoding::kPng),
              (dir / "missing.png").string() + ": cannot open");
  cv::imwrite((dir / "colour.png").string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar(9, 8, 7)));
  expectError(imageMsgFromFile(dir / "colour.png", 1, ImageEncoding::kPng),
              (dir / "colour.png").string() + ": not an 8-bit gray image");
}

TEST(StereoMsg, RoundTripsAndRefusesMismatchedImages) {
  StereoFrame f;
  f.utime = 1403715273262143;
  f.rectified = true;
  f.left = testImage(64, 40, 6);
  f.right = testImage(64, 40, 7);
  const auto msg = toMsg(f, ImageEncoding::kPng);
  ASSERT_TRUE(msg.ok()) << msg.error().message;
  const auto back = fromMsg(throughWire(*msg));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->utime, f.utime);
  EXPECT_TRUE(back->rectified);
  EXPECT_TRUE(sameImage(back->left, f.left));
  EXPECT_TRUE(sameImage(back->right, f.right));

  StereoFrame bad = f;
  bad.right = testImage(60, 40, 7);
  expectError(toMsg(bad, ImageEncoding::kGray8), "differ in size");
  evermap::stereo_image_t m = *msg;
  m.right = *toMsg(bad.right, f.utime, ImageEncoding::kGray8);
  expectError(fromMsg(m), "left 64x40 and right 60x40 differ in size");
  m = *msg;
  m.rectified = 3;
  expectError(fromMsg(m), "rectified must be 0 or 1");
  m = *msg;
  m.left.pixelformat = 0;
  expectError(fromMsg(m), "left: image_t at utime 1403715273262143: unknown pixelformat 0");
}

TEST(CalibrationMsg, RoundTripsEveryField) {
  core::StereoCalibration s;
  s.left = eurocLeft();
  s.right = eurocLeft();
  s.right.cx = 379.999;
  s.right.distortion[3] = -3.55590700e-05;
  s.right.body_T_cam = s.left.body_T_cam * core::SE3d(core::SO3d::exp(core::Vec3(0.01, 0.0, 0.0)),
                                                      core::Vec3(0.11, 0.0, 0.0));
  const auto back = fromMsg(throughWire(toMsg(s, 77)));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_FALSE(back->rectified);
  for (const auto& [a, b] : {std::pair{&back->left, &s.left}, std::pair{&back->right, &s.right}}) {
    EXPECT_EQ(a->width, b->width);
    EXPECT_EQ(a->height, b->height);
    EXPECT_EQ(a->fx, b->fx);
    EXPECT_EQ(a->fy, b->fy);
    EXPECT_EQ(a->cx, b->cx);
    EXPECT_EQ(a->cy, b->cy);
    EXPECT_EQ(a->distortion_model, b->distortion_model);
    EXPECT_EQ(a->distortion, b->distortion);
    EXPECT_LT((a->body_T_cam.matrix() - b->body_T_cam.matrix()).norm(), 1e-12);
  }
}

TEST(CalibrationMsg, ARectifiedPairKeepsItsDisparityOffsetThroughTheWire) {
  // KITTI's clip as evermap-kitti2lcm --disparity-offset 0.8 writes it: the offset is the right
  // camera's cx, so STEREO_CALIB carries it without a field of its own.
  core::StereoCalibration s;
  s.rectified = true;
  for (core::CameraCalibration* c : {&s.left, &s.right}) {
    c->width = 1241;
    c->height = 376;
    c->fx = c->fy = 718.856;
    c->cx = 607.1928;
    c->cy = 185.2157;
  }
  s.right.body_T_cam = core::SE3d(core::SO3d(), core::Vec3(0.537, 0.0, 0.0));
  const auto with = core::withDisparityOffset(s, 0.8);
  ASSERT_TRUE(with.ok()) << with.error().message;
  const auto back = fromMsg(throughWire(toMsg(*with, 5)));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(back->rectified);
  EXPECT_EQ(back->right.cx, with->right.cx);
  const auto cam = core::rectifiedStereoCamera(*back);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_NEAR(cam->disparityOffsetPx(), 0.8, 1e-12);
  EXPECT_EQ(static_cast<float>(cam->disparityOffsetPx()), 0.8f);  // what StereoDepth adds
  EXPECT_EQ(cam->cx(), 607.1928);
  // Without the offset the message is what it was before the offset existed.
  EXPECT_EQ(core::rectifiedStereoCamera(*fromMsg(throughWire(toMsg(s, 5))))->disparityOffsetPx(),
            0.0);
}

TEST(CalibrationMsg, MalformedCalibrationsAreRefused) {
  core::StereoCalibration s;
  s.left = eurocLeft();
  s.right = eurocLeft();
  s.right.body_T_cam = s.left.body_T_cam * core::SE3d(core::SO3d(), core::Vec3(0.11, 0, 0));
  const evermap::stereo_calib_t good = toMsg(s, 1);

  evermap::stereo_calib_t m = good;
  m.left.num_distortion = 5;
  expectError(fromMsg(m), "num_distortion 5 but 4 coefficients");
  m = good;
  m.right.fx = kNan;
  expectError(fromMsg(m), "right: camera_calib_t: focal length fx = nan");
  m = good;
  m.left.distortion_model = 7;
  expectError(fromMsg(m), "unknown distortion_model 7");
  m = good;
  m.left.body_T_cam[0] = 2.0;
  expectError(fromMsg(m), "body_T_cam is not a rigid transform");
  m = good;
  m.left.body_T_cam[3] = kNan;
  expectError(fromMsg(m), "non-finite body_T_cam");
  m = good;
  m.right.width = 640;
  m.right.cx = 300;
  expectError(fromMsg(m), "image sizes differ");
  m = good;
  std::copy_n(m.left.body_T_cam, 16, m.right.body_T_cam);
  expectError(fromMsg(m), "baseline is 0 m");
  m = good;
  m.rectified = 1;  // but distorted
  expectError(fromMsg(m), "marked rectified but a camera has a distortion model");
  m = good;
  m.rectified = -1;
  expectError(fromMsg(m), "rectified must be 0 or 1");
}

TEST(ImuMsg, RoundTripsAndLeavesANonFiniteValueToTheGateThatCountsIt) {
  imu::ImuSample s;
  s.utime = 1403715273262143LL;
  s.gyro_rad_s = Eigen::Vector3d(-0.099134701513277898, 0.14730578886832138, 0.02722713633111154);
  s.accel_m_s2 = Eigen::Vector3d(8.1476917083333333, -0.37592158333333331, -2.4026292499999999);
  const evermap::imu_t msg = throughWire(imu::toLcm(s));
  EXPECT_EQ(msg.utime, 1403715273262143LL);
  const imu::ImuSample back = imu::fromLcm(msg);
  EXPECT_EQ(back.utime, s.utime);
  EXPECT_EQ(back.gyro_rad_s, s.gyro_rad_s);
  EXPECT_EQ(back.accel_m_s2, s.accel_m_s2);
  // The conversion refuses nothing: the SampleGate every consumer applies drops and counts.
  evermap::imu_t bad = msg;
  bad.linear_acceleration[2] = std::numeric_limits<double>::infinity();
  imu::SampleGate gate;
  double dt_s = 0;
  EXPECT_EQ(gate.check(imu::fromLcm(bad), &dt_s), imu::GateVerdict::kDrop);
  EXPECT_EQ(gate.counts().non_finite, 1);
  EXPECT_EQ(gate.check(back, &dt_s), imu::GateVerdict::kAcceptAfterGap);  // the first
}

TEST(PoseMsg, RoundTripsPoseAndCovarianceInTangentOrder) {
  core::UncertainPose p;
  p.mean = core::SE3d(core::SO3d::exp(core::Vec3(0.3, -0.2, 2.0)), core::Vec3(1.0, -2.0, 0.5));
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Random();
  p.covariance = A * A.transpose() * 1e-3;
  p.covariance(0, 0) = 0.04;  // translation x first, as the tangent order (υ, ω) says
  const evermap::pose_t msg = throughWire(toMsg(123, p, 2, 5));
  EXPECT_EQ(msg.floor, 2);
  EXPECT_EQ(msg.session, 5);
  EXPECT_EQ(msg.covariance[0], 0.04);
  EXPECT_NEAR(msg.orientation[0], p.mean.quaternion().w(), 0.0);  // w first
  const auto back = fromMsg(msg);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_LT((back->mean.matrix() - p.mean.matrix()).norm(), 1e-15);
  EXPECT_EQ(back->covariance, p.covariance);
}

TEST(PoseMsg, MalformedPosesAreRefused) {
  const evermap::pose_t good = toMsg(9, core::UncertainPose{});
  evermap::pose_t m = good;
  m.position[1] = kNan;
  expectError(fromMsg(m), "pose_t at utime 9: translation is not finite");
  m = good;
  m.orientation[3] = kNan;
  expectError(fromMsg(m), "pose_t at utime 9: orientation is not finite");
  m = good;
  m.orientation[0] = 0.5;
  expectError(fromMsg(m), "not a unit quaternion");
  m = good;
  m.covariance[1] = 0.1;
  expectError(fromMsg(m), "covariance is not symmetric");
  m = good;
  m.covariance[7] = -0.1;
  expectError(fromMsg(m), "negative variance");
  m = good;
  m.covariance[35] = kNan;
  expectError(fromMsg(m), "non-finite covariance");
}

TEST(PoseFields, PoseFromMessageReadsBackWhatPutPoseWrote) {
  const core::SE3d pose(core::SO3d::exp(core::Vec3(0.3, -1.2, 2.0)), core::Vec3(1.5, -2.25, 7.0));
  double t[3], q[4];
  putPose(pose, t, q);
  const Expected<core::SE3d> back = poseFromMessage(t, q, "test");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->translation(), pose.translation());
  EXPECT_EQ(back->quaternion().coeffs(), core::SO3d(pose.quaternion()).quaternion().coeffs());
}

TEST(PoseFields, QuaternionFromMessageReturnsTheFieldsAsReadWhenNearlyUnit) {
  const double q[4] = {1.0005, 0.0, 0.0, 0.0};  // within the 1e-3 tolerance, not normalised
  const Expected<Eigen::Quaterniond> read = quaternionFromMessage(q, "test");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->w(), 1.0005);
}

TEST(PoseFields, NonFiniteOrNonUnitFieldsAreRefusedWithTheirName) {
  const double t[3] = {0.0, 0.0, 0.0};
  double q[4] = {1.0, 0.0, 0.0, 0.0};
  q[2] = kNan;
  expectError(quaternionFromMessage(q, "VO_DELTA 5"), "VO_DELTA 5: orientation is not finite");
  q[2] = 0.0;
  q[0] = 0.9;
  expectError(poseFromMessage(t, q, "REGISTER_RESULT"),
              "REGISTER_RESULT: orientation is not a unit quaternion");
  const double bad_t[3] = {0.0, kNan, 0.0};
  q[0] = 1.0;
  expectError(poseFromMessage(bad_t, q, "pose"), "pose: translation is not finite");
}

TEST(DecodeLcm, TruncatedForeignAndOverlongBytesAreRefused) {
  const auto imu = encode(imu::toLcm(imu::ImuSample{}));
  expectError(decodeLcm<evermap::imu_t>(imu.data(), 10, "IMU"), "IMU: not a valid imu_t");
  expectError(decodeLcm<evermap::pose_t>(imu.data(), static_cast<int64_t>(imu.size()), "POSE"),
              "POSE: not a valid pose_t (not a pose_t (type hash");
  std::vector<uint8_t> longer = imu;
  longer.push_back(0);
  expectError(decodeLcm<evermap::imu_t>(longer.data(), static_cast<int64_t>(longer.size()), "IMU"),
              "followed by 1 unexpected bytes");
  expectError(decodeLcm<evermap::imu_t>(nullptr, 0, "IMU"), "IMU: 0 bytes is not a valid imu_t");
}

TEST(DecodeLcm, ImageLengthsBeyondTheBufferAreRefusedBeforeAllocation) {
  const auto msg = *toMsg(testImage(16, 8, 8), 1, ImageEncoding::kGray8);
  std::vector<uint8_t> bytes = encode(msg);
  // The size field sits after hash(8) utime(8) width height row_stride pixelformat (16).
  for (uint32_t claimed : {0x7fffffffu, 0xfffffffbu, 129u}) {
    std::vector<uint8_t> b = bytes;
    b[32] = claimed >> 24;
    b[33] = (claimed >> 16) & 0xff;
    b[34] = (claimed >> 8) & 0xff;
    b[35] = claimed & 0xff;
    expectError(decodeLcm<evermap::image_t>(b.data(), static_cast<int64_t>(b.size()), "CAM"),
                "CAM: not a valid image_t (image_t.data: length ");
  }
}

TEST(DecodeLcm, RandomlyCorruptedStereoMessagesNeverCrashTheReceiver) {
  StereoFrame f;
  f.utime = 5;
  f.left = testImage(24, 12, 9);
  f.right = testImage(24, 12, 10);
  const auto png = encode(*toMsg(f, ImageEncoding::kPng));
  const auto gray = encode(*toMsg(f, ImageEncoding::kGray8));
  const auto zstd = encode(*toMsg(f, ImageEncoding::kZstd));
  std::mt19937 rng(17);
  int accepted = 0, refused = 0;
  for (const auto* original : {&png, &gray, &zstd}) {
    for (int trial = 0; trial < 3000; ++trial) {
      std::vector<uint8_t> b = *original;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int k = 0; k < flips; ++k) b[rng() % b.size()] = static_cast<uint8_t>(rng());
      if (rng() % 8 == 0) b.resize(rng() % b.size());  // and sometimes truncated
      const auto msg =
          decodeLcm<evermap::stereo_image_t>(b.data(), static_cast<int64_t>(b.size()), "S");
      if (!msg) {
        ++refused;
        continue;
      }
      const auto frame = fromMsg(*msg);
      if (frame) {
        ++accepted;
        EXPECT_EQ(frame->left.size(), frame->right.size());
        EXPECT_EQ(frame->left.type(), CV_8UC1);
      } else {
        ++refused;
      }
    }
  }
  // Both outcomes occur: a flipped pixel is still a valid message, a flipped length is not.
  EXPECT_GT(accepted, 0);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace evermap::messages
