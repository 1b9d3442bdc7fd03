// EuRoC ASL folder -> LCM log (to_lcm.h).
#include <algorithm>
#include <string>
#include <vector>

#include "core/messages/channels.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"
#include "tools/datasets/to_lcm.h"
#include "tools/datasets/to_lcm_events.h"
#include "tools/lcmlog/log_writer.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;
using detail::EventKind;
using detail::PendingEvent;

// The rows of one camera whose image file exists, sorted by time; counts the others.
Expected<std::vector<ImageEntry>> presentImages(const fs::path& cam_dir, int64_t* missing) {
  auto rows = readEurocImages(cam_dir / "data.csv");
  if (!rows) return rows.error();
  std::vector<ImageEntry> out;
  for (ImageEntry& e : *rows) {
    if (fs::exists(cam_dir / "data" / e.filename)) {
      out.push_back(std::move(e));
    } else {
      ++*missing;
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const ImageEntry& a, const ImageEntry& b) { return a.t_ns < b.t_ns; });
  for (size_t i = 1; i < out.size(); ++i) {
    if (out[i].t_ns == out[i - 1].t_ns) {
      return makeError((cam_dir / "data.csv").string(), ": time stamp ", out[i].t_ns,
                       " appears twice");
    }
  }
  return out;
}

struct StereoRow {
  int64_t t_ns;
  fs::path left, right;
};

}  // namespace

Expected<ConversionSummary> convertEurocToLcm(const fs::path& asl_folder, const fs::path& output,
                                              const EurocToLcmOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  fs::path mav0 = asl_folder / "mav0";
  if (!fs::is_directory(mav0)) {
    if (fs::is_directory(asl_folder / "cam0")) {
      mav0 = asl_folder;
    } else {
      return makeError(asl_folder.string(), ": not an EuRoC ASL folder (no mav0/ inside)");
    }
  }
  ConversionSummary summary;

  auto calibration =
      readEurocStereoCalibration(mav0 / "cam0/sensor.yaml", mav0 / "cam1/sensor.yaml");
  if (!calibration) return calibration.error();
  auto imu = readEurocImu(mav0 / "imu0/data.csv");
  if (!imu) return imu.error();

  // Stereo pairs: stamps present in both cameras (the rig is hardware-triggered, so the
  // stamps of a pair are equal).
  auto left = presentImages(mav0 / "cam0", &summary.skipped_missing_image);
  if (!left) return left.error();
  auto right = presentImages(mav0 / "cam1", &summary.skipped_missing_image);
  if (!right) return right.error();
  std::vector<StereoRow> pairs;
  size_t j = 0;
  for (const ImageEntry& l : *left) {
    while (j < right->size() && (*right)[j].t_ns < l.t_ns) ++j;
    if (j < right->size() && (*right)[j].t_ns == l.t_ns) {
      pairs.push_back(
          {l.t_ns, mav0 / "cam0/data" / l.filename, mav0 / "cam1/data" / (*right)[j].filename});
    }
  }
  summary.skipped_unpaired = static_cast<int64_t>(left->size() + right->size() - 2 * pairs.size());

  std::vector<StampedPose> truth;
  fs::path gt_file = options.ground_truth;
  if (gt_file.empty() && fs::is_regular_file(mav0 / "state_groundtruth_estimate0/data.csv")) {
    gt_file = mav0 / "state_groundtruth_estimate0/data.csv";
  }
  if (!gt_file.empty()) {
    auto gt = readEurocGroundTruth(gt_file);
    if (!gt) return gt.error();
    truth = std::move(*gt);
    summary.ground_truth = gt_file.string();
  }

  std::vector<PendingEvent> events;
  events.reserve(imu->size() + truth.size() + pairs.size());
  for (size_t i = 0; i < imu->size(); ++i) {
    events.push_back({messages::utimeFromNs((*imu)[i].t_ns), EventKind::kImu, i});
  }
  for (size_t i = 0; i < truth.size(); ++i) {
    events.push_back({messages::utimeFromNs(truth[i].t_ns), EventKind::kGroundTruth, i});
  }
  for (size_t i = 0; i < pairs.size(); ++i) {
    events.push_back({messages::utimeFromNs(pairs[i].t_ns), EventKind::kStereo, i});
  }
  if (pairs.empty()) return makeError(mav0.string(), ": no stereo pair with both image files");
  detail::sortByTime(&events);

  auto writer = messages::LogWriter::open(output);
  if (!writer) return writer.error();
  const messages::ImageEncoding enc = options.encoding;
  channels::CalibrationRepeat calib_repeat;
  if (Status s =
          detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, events.front().utime);
      !s)
    return s.error();
  for (const PendingEvent& e : events) {
    Status s = Ok{};
    switch (e.kind) {
      case EventKind::kImu:
        s = writer->write(channels::kImu, e.utime, messages::toMsg((*imu)[e.index]));
        break;
      case EventKind::kGroundTruth:
        s = writer->write(
            channels::kGroundTruth, e.utime,
            messages::toMsg(e.utime, core::UncertainPose{truth[e.index].world_T_body}));
        break;
      case EventKind::kStereo: {
        const StereoRow& row = pairs[e.index];
        evermap::stereo_image_t msg;
        msg.utime = e.utime;
        msg.rectified = 0;
        for (auto [file, cam, slot] : {std::tuple{&row.left, &calibration->left, &msg.left},
                                       std::tuple{&row.right, &calibration->right, &msg.right}}) {
          auto image = messages::imageMsgFromFile(*file, e.utime, enc);
          if (!image) return image.error();
          if (image->width != cam->width || image->height != cam->height) {
            return makeError(file->string(), ": image is ", image->width, "x", image->height,
                             ", the calibration says ", cam->width, "x", cam->height);
          }
          *slot = std::move(*image);
        }
        s = detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, e.utime);
        if (s) s = writer->write(channels::kStereo, e.utime, msg);
        break;
      }
    }
    if (!s) return s.error();
  }
  summary.messages = writer->counts();
  summary.bytes = writer->bytes();
  if (Status s = writer->commit(); !s) return s.error();
  return summary;
}

}  // namespace evermap::datasets
