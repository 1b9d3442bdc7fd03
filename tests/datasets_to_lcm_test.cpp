// tools/datasets/to_lcm and tools/lcmlog/log_writer: convert the real EuRoC excerpt and a
// KITTI stereo folder built from real frames, read the logs back with lcm::LogFile, and check
// counts, order, pixels and values against the files on disk; refusals leave nothing behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"
#include "tools/datasets/kitti.h"
#include "tools/datasets/to_lcm.h"
#include "tools/lcmlog/log_writer.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;
using messages::decodeLcm;
using messages::fromMsg;

using evermap::testing::ScratchDir;

struct Event {
  int64_t timestamp;
  std::string channel;
  std::vector<uint8_t> data;
};

std::vector<Event> readLog(const fs::path& file) {
  lcm::LogFile log(file.string(), "r");
  EXPECT_TRUE(log.good()) << file;
  std::vector<Event> out;
  for (const lcm::LogEvent* e = log.readNextEvent(); e != nullptr; e = log.readNextEvent()) {
    const auto* p = static_cast<const uint8_t*>(e->data);
    out.push_back({e->timestamp, e->channel, std::vector<uint8_t>(p, p + e->datalen)});
  }
  return out;
}

template <typename Msg>
Msg decode(const Event& e) {
  auto m = decodeLcm<Msg>(e.data.data(), static_cast<int64_t>(e.data.size()), e.channel);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return *m;
}

std::map<std::string, int64_t> countChannels(const std::vector<Event>& events) {
  std::map<std::string, int64_t> n;
  for (const Event& e : events) ++n[e.channel];
  return n;
}

bool samePixels(const cv::Mat& a, const fs::path& png) {
  const cv::Mat b = cv::imread(png.string(), cv::IMREAD_UNCHANGED);
  return !b.empty() && a.size() == b.size() && a.type() == b.type() &&
         cv::norm(a, b, cv::NORM_INF) == 0.0;
}

bool noTemporaryFiles(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().string().find(".tmp.") != std::string::npos) return false;
  }
  return true;
}

// Checks the structure every converted log has: the calibration first, events in time order,
// each event stamped with its message's utime.
void expectOrderedWithCalibrationFirst(const std::vector<Event>& events) {
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front().channel, channels::kStereoCalib);
  for (size_t i = 1; i < events.size(); ++i) {
    ASSERT_LE(events[i - 1].timestamp, events[i].timestamp) << "event " << i;
  }
  for (const Event& e : events) {
    int64_t utime = 0;
    if (e.channel == channels::kImu) utime = decode<evermap::imu_t>(e).utime;
    if (e.channel == channels::kGroundTruth) utime = decode<evermap::pose_t>(e).utime;
    if (e.channel == channels::kStereoCalib) utime = decode<evermap::stereo_calib_t>(e).utime;
    if (e.channel == channels::kStereo) utime = decode<evermap::stereo_image_t>(e).utime;
    ASSERT_EQ(utime, e.timestamp) << e.channel;
  }
  // Calibration is state (docs/contracts.md): every pair has one at most a period before it.
  int64_t last_calibration = -1;
  for (const Event& e : events) {
    if (e.channel == channels::kStereoCalib) last_calibration = e.timestamp;
    if (e.channel != channels::kStereo) continue;
    ASSERT_GE(last_calibration, 0);
    EXPECT_LE(e.timestamp - last_calibration,
              static_cast<int64_t>(channels::kCalibrationPeriodS * 1e6));
  }
}

TEST(EurocToLcm, TheRealExcerptRoundTripsWithEveryMessageAndPixel) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const ScratchDir scratch;
  const fs::path out_dir = scratch.path();
  const fs::path log = out_dir / "v101.lcmlog";
  EurocToLcmOptions options;
  options.ground_truth = dir / "groundtruth_openvins/V1_01_easy.csv";
  const auto summary = convertEurocToLcm(dir, log, options);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  std::printf("%s", summary->report().c_str());
  EXPECT_EQ(summary->skipped_missing_image, 4);  // cam1/data.csv lists 4 rows without a file
  EXPECT_EQ(summary->skipped_unpaired, 0);
  EXPECT_TRUE(noTemporaryFiles(out_dir));
  EXPECT_EQ(static_cast<int64_t>(fs::file_size(log)), summary->bytes);

  const auto imu = readEurocImu(dir / "mav0/imu0/data.csv");
  const auto gt = readEurocGroundTruth(options.ground_truth);
  const auto left_rows = readEurocImages(dir / "mav0/cam0/data.csv");
  ASSERT_TRUE(imu.ok() && gt.ok() && left_rows.ok());

  const std::vector<Event> events = readLog(log);
  const auto counts = countChannels(events);
  EXPECT_EQ(counts.at(channels::kStereoCalib), 5);  // at the start, then once a second of the 4.7 s
  EXPECT_EQ(counts.at(channels::kStereo), 95);
  EXPECT_EQ(counts.at(channels::kImu), 29120);
  EXPECT_EQ(counts.at(channels::kGroundTruth), static_cast<int64_t>(gt->size()));  // 2895
  EXPECT_EQ(counts.size(), 4u);
  EXPECT_EQ(counts, summary->messages);
  expectOrderedWithCalibrationFirst(events);

  // The calibration is the sensor.yaml pair, unrectified.
  const auto calib = fromMsg(decode<evermap::stereo_calib_t>(events.front()));
  ASSERT_TRUE(calib.ok()) << calib.error().message;
  const auto expected_calib =
      readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml", dir / "mav0/cam1/sensor.yaml");
  EXPECT_FALSE(calib->rectified);
  EXPECT_EQ(calib->left.fx, expected_calib->left.fx);
  EXPECT_EQ(calib->right.distortion, expected_calib->right.distortion);
  EXPECT_LT((calib->right_T_left().matrix() - expected_calib->right_T_left().matrix()).norm(),
            1e-12);

  // Every stereo pair decodes to the pixels of the PNG files on disk, at the row's stamp.
  size_t pair = 0, imu_i = 0, gt_i = 0;
  for (const Event& e : events) {
    if (e.channel == channels::kStereo) {
      const auto frame = fromMsg(decode<evermap::stereo_image_t>(e));
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      const ImageEntry& row = (*left_rows)[pair++];
      EXPECT_EQ(frame->utime, messages::utimeFromNs(row.t_ns));
      EXPECT_FALSE(frame->rectified);
      EXPECT_TRUE(samePixels(frame->left, dir / "mav0/cam0/data" / row.filename)) << row.filename;
      EXPECT_TRUE(samePixels(frame->right, dir / "mav0/cam1/data" / row.filename)) << row.filename;
    } else if (e.channel == channels::kImu) {
      const imu::ImuSample s = imu::fromLcm(decode<evermap::imu_t>(e));
      const imu::ImuSample& want = (*imu)[imu_i++];
      EXPECT_EQ(s.utime, want.utime);
      EXPECT_EQ(s.gyro_rad_s, want.gyro_rad_s);
      EXPECT_EQ(s.accel_m_s2, want.accel_m_s2);
    } else if (e.channel == channels::kGroundTruth) {
      const auto p = fromMsg(decode<evermap::pose_t>(e));
      ASSERT_TRUE(p.ok());
      const StampedPose& want = (*gt)[gt_i++];
      EXPECT_LT((p->mean.matrix() - want.world_T_body.matrix()).norm(), 1e-12);
      EXPECT_EQ(p->covariance, core::Mat6::Zero());
    }
  }
  EXPECT_EQ(pair, 95u);
  EXPECT_EQ(imu_i, imu->size());
}

TEST(EurocToLcm, RawImagesAreStoredAsGray8) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const ScratchDir scratch;
  const fs::path log = scratch.path() / "raw.lcmlog";
  EurocToLcmOptions options;
  options.encoding = messages::ImageEncoding::kGray8;
  const auto summary = convertEurocToLcm(dir / "mav0", log, options);  // mav0 itself accepted
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  EXPECT_TRUE(summary->ground_truth.empty());  // no state_groundtruth_estimate0/data.csv here
  EXPECT_EQ(summary->messages.count(channels::kGroundTruth), 0u);
  const auto rows = readEurocImages(dir / "mav0/cam0/data.csv");
  size_t pair = 0;
  for (const Event& e : readLog(log)) {
    if (e.channel != channels::kStereo) continue;
    const auto msg = decode<evermap::stereo_image_t>(e);
    EXPECT_EQ(msg.left.pixelformat, evermap::image_t::FORMAT_GRAY8);
    EXPECT_EQ(msg.right.pixelformat, evermap::image_t::FORMAT_GRAY8);
    EXPECT_EQ(msg.left.size, 752 * 480);
    EXPECT_EQ(msg.left.row_stride, 752);
    if (pair % 20 == 0) {  // pixels of a few pairs (the PNG test checks all of them)
      const auto frame = fromMsg(msg);
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      const std::string& name = (*rows)[pair].filename;
      EXPECT_TRUE(samePixels(frame->left, dir / "mav0/cam0/data" / name)) << name;
      EXPECT_TRUE(samePixels(frame->right, dir / "mav0/cam1/data" / name)) << name;
    }
    ++pair;
  }
  EXPECT_EQ(pair, 95u);
}

// A small ASL folder built from the real excerpt: 5 pairs, one image replaced.
fs::path smallAslFolder(const fs::path& real, const fs::path& root) {
  const auto rows = readEurocImages(real / "mav0/cam0/data.csv");
  for (const char* cam : {"cam0", "cam1"}) {
    const fs::path d = root / "mav0" / cam;
    fs::create_directories(d / "data");
    fs::copy_file(real / "mav0" / cam / "sensor.yaml", d / "sensor.yaml");
    std::ofstream csv(d / "data.csv");
    csv << "#timestamp [ns],filename\n";
    for (int i = 0; i < 5; ++i) {
      csv << (*rows)[i].t_ns << "," << (*rows)[i].filename << "\n";
      fs::create_symlink(real / "mav0" / cam / "data" / (*rows)[i].filename,
                         d / "data" / (*rows)[i].filename);
    }
  }
  fs::create_directories(root / "mav0/imu0");
  std::ifstream in(real / "mav0/imu0/data.csv");
  std::ofstream imu(root / "mav0/imu0/data.csv");
  std::string line;
  for (int i = 0; i < 100 && std::getline(in, line); ++i) imu << line << "\n";
  return root;
}

TEST(EurocToLcm, ACorruptImageIsAnErrorNamingItAndLeavesNoLog) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const ScratchDir scratch;
  const fs::path root = smallAslFolder(dir, scratch.path() / "asl");
  const fs::path out_dir = root.parent_path();
  ASSERT_TRUE(convertEurocToLcm(root, out_dir / "ok.lcmlog", {}).ok());

  const auto rows = readEurocImages(root / "mav0/cam1/data.csv");
  const fs::path victim = root / "mav0/cam1/data" / (*rows)[3].filename;
  fs::remove(victim);
  std::ofstream(victim) << "\x89PNG\r\n\x1a\n truncated";
  const auto r = convertEurocToLcm(root, out_dir / "bad.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(victim.string()), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);  // one line
  EXPECT_FALSE(fs::exists(out_dir / "bad.lcmlog"));
  EXPECT_TRUE(noTemporaryFiles(out_dir));
}

TEST(EurocToLcm, MissingInputsAreRefusedByName) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const ScratchDir scratch;
  const fs::path out = scratch.path();
  auto r = convertEurocToLcm(out, out / "x.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no mav0/ inside"), std::string::npos);
  EurocToLcmOptions options;
  options.ground_truth = "/nonexistent/gt.csv";
  r = convertEurocToLcm(dir, out / "x.lcmlog", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent/gt.csv: ground-truth file not found"),
            std::string::npos);
  r = convertEurocToLcm(dir, out / "no_such_folder" / "x.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("does not exist"), std::string::npos) << r.error().message;
  EXPECT_TRUE(fs::is_empty(out));
}

// A KITTI stereo sequence folder from the first `n` frames of the real monocular one, with
// image_1 pointing at the image_0 files (the folder has no right camera).
fs::path kittiStereoFolder(const fs::path& real, const fs::path& root, int n) {
  fs::create_directories(root / "image_0");
  fs::create_directories(root / "image_1");
  fs::copy_file(real / "calib.txt", root / "calib.txt");
  for (const char* name : {"times.txt", "poses.txt"}) {
    std::ifstream in(real / name);
    std::ofstream out(root / name);
    std::string line;
    for (int i = 0; i < n && std::getline(in, line); ++i) out << line << "\n";
  }
  for (int i = 0; i < n; ++i) {
    char f[16];
    std::snprintf(f, sizeof f, "%06d.png", i);
    fs::create_symlink(real / "image_0" / f, root / "image_0" / f);
    fs::create_symlink(real / "image_0" / f, root / "image_1" / f);
  }
  return root;
}

TEST(KittiToLcm, AStereoFolderRoundTripsWithCalibrationImagesAndPoses) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const ScratchDir scratch;
  const fs::path out_dir = scratch.path();
  const fs::path seq = kittiStereoFolder(dir, out_dir / "07", 20);
  const fs::path log = out_dir / "kitti07.lcmlog";
  const auto summary = convertKittiToLcm(seq, log, {});
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  std::printf("%s", summary->report().c_str());
  EXPECT_EQ(summary->skipped_missing_image, 0);
  EXPECT_EQ(summary->ground_truth, (seq / "poses.txt").string());

  const std::vector<Event> events = readLog(log);
  const auto counts = countChannels(events);
  EXPECT_GE(counts.at(channels::kStereoCalib), 1);
  EXPECT_EQ(counts.at(channels::kStereo), 20);
  EXPECT_EQ(counts.at(channels::kGroundTruth), 20);
  EXPECT_EQ(counts.size(), 3u);
  expectOrderedWithCalibrationFirst(events);

  const auto calib = fromMsg(decode<evermap::stereo_calib_t>(events.front()));
  ASSERT_TRUE(calib.ok()) << calib.error().message;
  EXPECT_TRUE(calib->rectified);
  const auto cam = core::rectifiedStereoCamera(*calib);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_NEAR(cam->baselineM(), 379.8145 / 707.0912, 1e-12);
  EXPECT_EQ(cam->width(), 1226);
  EXPECT_EQ(cam->height(), 370);

  const auto times = readKittiTimes(seq / "times.txt");
  const auto poses = readKittiPoses(seq / "poses.txt");
  int frame = 0, pose = 0;
  for (const Event& e : events) {
    if (e.channel == channels::kStereo) {
      const auto f = fromMsg(decode<evermap::stereo_image_t>(e));
      ASSERT_TRUE(f.ok()) << f.error().message;
      EXPECT_TRUE(f->rectified);
      EXPECT_EQ(f->utime, messages::utimeFromNs((*times)[frame]));
      char name[16];
      std::snprintf(name, sizeof name, "%06d.png", frame);
      EXPECT_TRUE(samePixels(f->left, dir / "image_0" / name)) << name;
      EXPECT_TRUE(samePixels(f->right, dir / "image_0" / name)) << name;
      ++frame;
    } else if (e.channel == channels::kGroundTruth) {
      const auto p = fromMsg(decode<evermap::pose_t>(e));
      ASSERT_TRUE(p.ok());
      EXPECT_LT((p->mean.matrix() - (*poses)[pose].matrix()).norm(), 1e-12);
      // A pose precedes the image of its frame (same utime: ground truth first).
      EXPECT_EQ(pose, frame);
      ++pose;
    }
  }
  EXPECT_EQ(frame, 20);
}

TEST(KittiToLcm, TheRealMonocularFolderIsRefusedForItsMissingRightCamera) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const ScratchDir scratch;
  const fs::path out = scratch.path();
  const auto r = convertKittiToLcm(dir, out / "x.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find((dir / "image_1").string() + ": no right images"),
            std::string::npos)
      << r.error().message;
  EXPECT_TRUE(fs::is_empty(out));
}

TEST(KittiToLcm, MissingFramesAreSkippedAndCountedAndPoseCountsMustAgree) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const ScratchDir scratch;
  const fs::path out_dir = scratch.path();
  const fs::path seq = kittiStereoFolder(dir, out_dir / "07", 10);
  fs::remove(seq / "image_1/000004.png");
  auto summary = convertKittiToLcm(seq, out_dir / "a.lcmlog", {});
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  EXPECT_EQ(summary->skipped_missing_image, 1);
  EXPECT_EQ(summary->messages.at(channels::kStereo), 9);
  EXPECT_EQ(summary->messages.at(channels::kGroundTruth), 10);

  KittiToLcmOptions options;
  options.sequence.poses = dir / "poses.txt";  // 160 poses for 10 frames
  const auto r = convertKittiToLcm(seq, out_dir / "b.lcmlog", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("160 poses but"), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(out_dir / "b.lcmlog"));
}

TEST(KittiToLcm, ADisparityOffsetIsWrittenAsTheRightCamerasCxOfEveryCalibration) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const ScratchDir scratch;
  const fs::path out_dir = scratch.path();
  const fs::path seq = kittiStereoFolder(dir, out_dir / "07", 3);
  KittiToLcmOptions options;
  options.encoding = messages::ImageEncoding::kGray8;
  options.disparity_offset_px = 0.8;
  const auto summary = convertKittiToLcm(seq, out_dir / "a.lcmlog", options);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  int calibrations = 0;
  for (const Event& e : readLog(out_dir / "a.lcmlog")) {
    if (e.channel != channels::kStereoCalib) continue;
    ++calibrations;
    const auto calib = fromMsg(decode<evermap::stereo_calib_t>(e));
    ASSERT_TRUE(calib.ok()) << calib.error().message;
    EXPECT_EQ(calib->left.cx, 601.8873);  // calib.txt's, for both cameras
    EXPECT_EQ(calib->right.cx, 601.8873 + 0.8);
    const auto cam = core::rectifiedStereoCamera(*calib);
    ASSERT_TRUE(cam.ok()) << cam.error().message;
    EXPECT_NEAR(cam->disparityOffsetPx(), 0.8, 1e-12);
  }
  EXPECT_GE(calibrations, 1);

  options.disparity_offset_px = 400.0;  // beyond a quarter of the 1226 px width
  const auto r = convertKittiToLcm(seq, out_dir / "b.lcmlog", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("calib.txt with the disparity offset 400 px"), std::string::npos)
      << r.error().message;
  EXPECT_FALSE(fs::exists(out_dir / "b.lcmlog"));
}

TEST(KittiToLcm, TheStereoClipConvertsInItsOwnLayoutWithAFrameRate) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");  // image_l/, image_r/, unlabelled calib.txt
  const ScratchDir scratch;
  const fs::path log = scratch.path() / "clip.lcmlog";
  KittiToLcmOptions options;
  options.sequence.rate_hz = 10.0;
  const auto summary = convertKittiToLcm(dir, log, options);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  EXPECT_EQ(summary->messages.at(channels::kStereo), 51);
  EXPECT_EQ(summary->messages.at(channels::kGroundTruth), 51);
  int frame = 0;
  for (const Event& e : readLog(log)) {
    if (e.channel != channels::kStereo) continue;
    const auto f = fromMsg(decode<evermap::stereo_image_t>(e));
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_EQ(f->utime, frame * 100000) << "frame " << frame << " at 10 Hz";
    if (frame == 7) {
      EXPECT_TRUE(samePixels(f->left, dir / "image_l" / "000007.png"));
      EXPECT_TRUE(samePixels(f->right, dir / "image_r" / "000007.png"));
    }
    ++frame;
  }
  EXPECT_EQ(frame, 51);
}

TEST(KittiToLcm, WithoutTimesOrARateOrWithAMissingFolderTheErrorSaysWhatToGive) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const ScratchDir scratch;
  auto r = convertKittiToLcm(dir, scratch.path() / "a.lcmlog", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(
      r.error().message.find("times.txt: no such file; give the frame rate instead (--rate HZ)"),
      std::string::npos)
      << r.error().message;
  KittiToLcmOptions options;
  options.sequence.rate_hz = -1.0;
  r = convertKittiToLcm(dir, scratch.path() / "b.lcmlog", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("frame rate -1 Hz"), std::string::npos) << r.error().message;
  options.sequence.rate_hz = 10.0;
  options.sequence.right_folder = "image_x";
  r = convertKittiToLcm(dir, scratch.path() / "c.lcmlog", options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("image_x: no right images"), std::string::npos)
      << r.error().message;
  EXPECT_TRUE(fs::is_empty(scratch.path()));
}

TEST(LogWriter, OnlyACommittedLogAppearsUnderItsName) {
  const ScratchDir scratch;
  const fs::path dir = scratch.path();
  {
    auto w = messages::LogWriter::open(dir / "abandoned.lcmlog");
    ASSERT_TRUE(w.ok()) << w.error().message;
    ASSERT_TRUE(w->write("IMU", 1, imu::toLcm(imu::ImuSample{})).ok());
    EXPECT_TRUE(fs::exists(w->temporaryPath()));
  }  // destroyed without commit
  EXPECT_TRUE(fs::is_empty(dir));

  auto w = messages::LogWriter::open(dir / "kept.lcmlog");
  ASSERT_TRUE(w.ok());
  ASSERT_TRUE(w->write("IMU", 5, imu::toLcm(imu::ImuSample{})).ok());
  ASSERT_TRUE(w->write("IMU", 6, imu::toLcm(imu::ImuSample{})).ok());
  ASSERT_TRUE(w->commit().ok());
  EXPECT_FALSE(w->commit().ok());  // closed
  const auto events = readLog(dir / "kept.lcmlog");
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].timestamp, 6);
  EXPECT_TRUE(noTemporaryFiles(dir));

  auto bad = messages::LogWriter::open(dir / "missing/x.lcmlog");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("does not exist"), std::string::npos);
  EXPECT_FALSE(messages::LogWriter::open(dir).ok());  // a folder
}

}  // namespace
}  // namespace evermap::datasets
