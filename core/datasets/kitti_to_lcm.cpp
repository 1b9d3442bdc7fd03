// KITTI odometry sequence -> LCM log (to_lcm.h).
#include <cstdio>
#include <string>
#include <vector>

#include "core/datasets/kitti.h"
#include "core/datasets/to_lcm.h"
#include "core/datasets/to_lcm_events.h"
#include "core/messages/channels.h"
#include "core/messages/log_writer.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;
using detail::EventKind;
using detail::PendingEvent;

std::string frameName(size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu.png", i);
  return buf;
}

}  // namespace

Expected<ConversionSummary> convertKittiToLcm(const fs::path& sequence, const fs::path& output,
                                              const KittiToLcmOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  const fs::path left_dir = sequence / "image_0", right_dir = sequence / "image_1";
  if (!fs::is_directory(left_dir)) {
    return makeError(left_dir.string(), ": no left images (not a KITTI odometry sequence?)");
  }
  if (!fs::is_directory(right_dir)) {
    return makeError(right_dir.string(), ": no right images: stereo needs image_0 and image_1 "
                                         "(this folder is monocular)");
  }
  ConversionSummary summary;
  auto projections = readKittiCalib(sequence / "calib.txt");
  if (!projections) return projections.error();
  auto times = readKittiTimes(sequence / "times.txt");
  if (!times) return times.error();

  std::vector<core::SE3d> poses;
  fs::path poses_file = options.poses;
  if (poses_file.empty() && fs::is_regular_file(sequence / "poses.txt")) {
    poses_file = sequence / "poses.txt";
  }
  if (!poses_file.empty()) {
    auto p = readKittiPoses(poses_file);
    if (!p) return p.error();
    if (p->size() != times->size()) {
      return makeError(poses_file.string(), ": ", p->size(), " poses but ",
                       (sequence / "times.txt").string(), " has ", times->size(), " frames");
    }
    poses = std::move(*p);
    summary.ground_truth = poses_file.string();
  }

  // Frames with both images; the image size comes from the first one.
  std::vector<size_t> frames;
  for (size_t i = 0; i < times->size(); ++i) {
    if (fs::exists(left_dir / frameName(i)) && fs::exists(right_dir / frameName(i))) {
      frames.push_back(i);
    } else {
      ++summary.skipped_missing_image;
    }
  }
  if (frames.empty()) return makeError(sequence.string(), ": no frame with both images");
  auto first = messages::imageMsgFromFile(left_dir / frameName(frames.front()), 0,
                                          messages::ImageEncoding::kGray8);  // for its size
  if (!first) return first.error();
  auto calibration = kittiStereoCalibration(*projections, first->width, first->height,
                                            (sequence / "calib.txt").string());
  if (!calibration) return calibration.error();

  std::vector<PendingEvent> events;
  for (size_t i = 0; i < poses.size(); ++i) {
    events.push_back({messages::utimeFromNs((*times)[i]), EventKind::kGroundTruth, i});
  }
  for (size_t i : frames) {
    events.push_back({messages::utimeFromNs((*times)[i]), EventKind::kStereo, i});
  }
  detail::sortByTime(&events);

  auto writer = messages::LogWriter::open(output);
  if (!writer) return writer.error();
  channels::CalibrationRepeat calib_repeat;
  if (Status s = detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, events.front().utime); !s)
    return s.error();
  for (const PendingEvent& e : events) {
    Status s = Ok{};
    if (e.kind == EventKind::kGroundTruth) {
      s = writer->write(channels::kGroundTruth, e.utime,
                        messages::toMsg(e.utime, core::UncertainPose{poses[e.index]}));
    } else {
      evermap::stereo_image_t msg;
      msg.utime = e.utime;
      msg.rectified = 1;
      for (auto [dir, slot] : {std::pair{&left_dir, &msg.left}, std::pair{&right_dir, &msg.right}}) {
        const fs::path file = *dir / frameName(e.index);
        auto image = messages::imageMsgFromFile(file, e.utime, options.encoding);
        if (!image) return image.error();
        if (image->width != calibration->left.width || image->height != calibration->left.height) {
          return makeError(file.string(), ": image is ", image->width, "x", image->height,
                           ", the sequence's first image is ", calibration->left.width, "x",
                           calibration->left.height);
        }
        *slot = std::move(*image);
      }
      s = detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, e.utime);
      if (s) s = writer->write(channels::kStereo, e.utime, msg);
    }
    if (!s) return s.error();
  }
  summary.messages = writer->counts();
  summary.bytes = writer->bytes();
  if (Status s = writer->commit(); !s) return s.error();
  return summary;
}

}  // namespace evermap::datasets
