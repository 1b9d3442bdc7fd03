// KITTI odometry sequence -> LCM log (to_lcm.h).
#include <string>
#include <vector>

#include "core/messages/channels.h"
#include "tools/datasets/kitti.h"
#include "tools/datasets/to_lcm.h"
#include "tools/datasets/to_lcm_events.h"
#include "tools/lcmlog/log_writer.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;
using detail::EventKind;
using detail::PendingEvent;

}  // namespace

Expected<ConversionSummary> convertKittiToLcm(const fs::path& sequence, const fs::path& output,
                                              const KittiToLcmOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto seq = readKittiSequence(sequence, options.sequence);
  if (!seq) return seq.error();
  ConversionSummary summary;
  summary.skipped_missing_image = seq->skipped_missing_image;
  if (!seq->poses.empty()) summary.ground_truth = seq->poses_file.string();
  const std::vector<int64_t>& times = seq->times_ns;
  const std::vector<core::SE3d>& poses = seq->poses;
  const std::vector<size_t>& frames = seq->frames;
  // The image size comes from the first frame.
  auto first = messages::imageMsgFromFile(seq->leftImage(frames.front()), 0,
                                          messages::ImageEncoding::kGray8);  // for its size
  if (!first) return first.error();
  auto from_file = kittiStereoCalibration(seq->projections, first->width, first->height,
                                          seq->calib_file.string());
  if (!from_file) return from_file.error();
  auto calibration = core::withDisparityOffset(*from_file, options.disparity_offset_px);
  if (!calibration) {
    return makeError(seq->calib_file.string(), " with the disparity offset ",
                     options.disparity_offset_px, " px: ", calibration.error().message);
  }

  std::vector<PendingEvent> events;
  for (size_t i = 0; i < poses.size(); ++i) {
    events.push_back({messages::utimeFromNs(times[i]), EventKind::kGroundTruth, i});
  }
  for (size_t i : frames) {
    events.push_back({messages::utimeFromNs(times[i]), EventKind::kStereo, i});
  }
  detail::sortByTime(&events);

  channels::CalibrationRepeat calib_repeat;
  auto writer = detail::openStereoLog(output, calib_repeat, *calibration, events.front().utime);
  if (!writer) return writer.error();
  return detail::writeEvents(*writer, events, summary, [&](const PendingEvent& e) -> Status {
    if (e.kind == EventKind::kGroundTruth) {
      return writer->write(channels::kGroundTruth, e.utime,
                           messages::toMsg(e.utime, core::UncertainPose{poses[e.index]}));
    }
    evermap::stereo_image_t msg;
    msg.utime = e.utime;
    msg.rectified = 1;
    for (auto [file, slot] : {std::pair{seq->leftImage(e.index), &msg.left},
                              std::pair{seq->rightImage(e.index), &msg.right}}) {
      auto image = messages::imageMsgFromFile(file, e.utime, options.encoding);
      if (!image) return image.error();
      if (image->width != calibration->left.width || image->height != calibration->left.height) {
        return makeError(file.string(), ": image is ", image->width, "x", image->height,
                         ", the sequence's first image is ", calibration->left.width, "x",
                         calibration->left.height);
      }
      *slot = std::move(*image);
    }
    Status s = detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, e.utime);
    if (s) s = writer->write(channels::kStereo, e.utime, msg);
    return s;
  });
}

}  // namespace evermap::datasets
