// TUM RGB-D sequence -> LCM log (to_lcm.h).
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/features/gray_image.h"
#include "core/messages/channels.h"
#include "core/messages/rgbd_convert.h"
#include "tools/datasets/to_lcm.h"
#include "tools/datasets/to_lcm_events.h"
#include "tools/lcmlog/log_writer.h"

#include <evermap/accel_t.hpp>
#include <evermap/rgbd_calib_t.hpp>

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;
using detail::EventKind;
using detail::PendingEvent;

// The image in `file` as stored (any depth and channels); an error names the file.
Expected<cv::Mat> readImage(const fs::path& file) {
  cv::Mat image;
  try {
    image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return makeError(file.string(), ": cannot read (", e.msg, ")");
  }
  if (image.empty()) return makeError(file.string(), ": missing, corrupt or not an image");
  return image;
}

Expected<cv::Mat> readGray(const fs::path& file) {
  auto image = readImage(file);
  if (!image) return image.error();
  if (image->depth() != CV_8U) return makeError(file.string(), ": not an 8-bit image");
  std::optional<cv::Mat> gray = core::toGray(*image);
  if (!gray) return makeError(file.string(), ": ", image->channels(), " channels (need 1, 3 or 4)");
  return *gray;
}

Expected<cv::Mat> readDepth(const fs::path& file) {
  auto depth = readImage(file);
  if (!depth) return depth.error();
  if (depth->type() != CV_16UC1) {
    return makeError(file.string(), ": depth must be 16-bit one-channel, is ",
                     8 * static_cast<int>(depth->elemSize1()), "-bit with ", depth->channels(),
                     " channels");
  }
  return *depth;
}

// The RGB-D message of the sequence's frame `k`: its colour image as gray and its depth,
// both checked against the calibration's size.
Expected<rgbd_image_t> rgbdMessage(const fs::path& folder, const TumRgbdSequence& seq, size_t k,
                                   int64_t utime, const core::CameraCalibration& camera,
                                   const std::string& calibration_name,
                                   const TumToLcmOptions& options) {
  const auto [ci, di] = seq.frames[k];
  messages::RgbdFrame f;
  f.utime = utime;
  f.depth_utime = messages::utimeFromNs(seq.depth[di].t_ns);
  f.depth_scale_m = options.depth_scale_m;
  f.camera = camera;
  const fs::path color_file = folder / seq.color[ci].file;
  const fs::path depth_file = folder / seq.depth[di].file;
  auto gray = readGray(color_file);
  if (!gray) return gray.error();
  auto depth = readDepth(depth_file);
  if (!depth) return depth.error();
  for (const auto& [file, image] :
       {std::pair{&color_file, &*gray}, std::pair{&depth_file, &*depth}}) {
    if (image->cols != camera.width || image->rows != camera.height) {
      return makeError(file->string(), ": image is ", image->cols, "x", image->rows,
                       ", the calibration (", calibration_name, ") is ", camera.width, "x",
                       camera.height);
    }
  }
  f.gray = std::move(*gray);
  f.depth = std::move(*depth);
  auto msg = messages::toMsg(f, options.encoding);
  if (!msg) return makeError(color_file.string(), ": ", msg.error().message);
  return msg;
}

}  // namespace

Expected<ConversionSummary> convertTumRgbdToLcm(const fs::path& folder, const fs::path& output,
                                                const TumToLcmOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto seq = readTumRgbdSequence(folder, options.sequence);
  if (!seq) return seq.error();
  const std::string calibration_name =
      options.calibration.empty() ? tumCalibrationNameFor(folder) : options.calibration;
  auto camera = tumCalibration(calibration_name);
  if (!camera) return camera.error();
  ConversionSummary summary;
  summary.skipped_unpaired = seq->unassociated_color;
  if (!seq->ground_truth.empty()) summary.ground_truth = (folder / "groundtruth.txt").string();

  std::vector<PendingEvent> events;
  // kImu orders the accelerometer like an IMU (before an image of the same stamp), kStereo
  // stands for the image.
  for (size_t i = 0; i < seq->accelerometer.size(); ++i) {
    events.push_back({messages::utimeFromNs(seq->accelerometer[i].t_ns), EventKind::kImu, i});
  }
  for (size_t i = 0; i < seq->ground_truth.size(); ++i) {
    events.push_back(
        {messages::utimeFromNs(seq->ground_truth[i].t_ns), EventKind::kGroundTruth, i});
  }
  for (size_t k = 0; k < seq->frames.size(); ++k) {
    const int64_t t = seq->color[seq->frames[k].first].t_ns;
    events.push_back({messages::utimeFromNs(t), EventKind::kStereo, k});
  }
  detail::sortByTime(&events);

  auto writer = messages::LogWriter::open(output);
  if (!writer) return writer.error();
  // RGBD_CALIB first and before the first frame of every period, as STEREO_CALIB.
  channels::CalibrationRepeat calib_repeat;
  auto writeCalibrationIfDue = [&](int64_t utime) -> Status {
    if (!calib_repeat.due(utime)) return Ok{};
    evermap::rgbd_calib_t msg;
    msg.utime = utime;
    msg.camera = messages::toMsg(*camera);
    return writer->write(channels::kRgbdCalib, utime, msg);
  };
  if (Status s = writeCalibrationIfDue(events.front().utime); !s) return s.error();
  return detail::writeEvents(*writer, events, summary, [&](const PendingEvent& e) -> Status {
    if (e.kind == EventKind::kImu) {
      evermap::accel_t msg;
      msg.utime = e.utime;
      for (int i = 0; i < 3; ++i)
        msg.linear_acceleration[i] = seq->accelerometer[e.index].accel_m_s2[i];
      return writer->write(channels::kAccel, e.utime, msg);
    }
    if (e.kind == EventKind::kGroundTruth) {
      return writer->write(
          channels::kGroundTruth, e.utime,
          messages::toMsg(e.utime, core::UncertainPose{seq->ground_truth[e.index].world_T_body}));
    }
    auto msg = rgbdMessage(folder, *seq, e.index, e.utime, *camera, calibration_name, options);
    if (!msg) return msg.error();
    Status s = writeCalibrationIfDue(e.utime);
    if (s) s = writer->write(channels::kRgbd, e.utime, *msg);
    return s;
  });
}

}  // namespace evermap::datasets
