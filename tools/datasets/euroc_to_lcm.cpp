// EuRoC ASL folder -> LCM log (to_lcm.h).
#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "core/imu/lcm_convert.h"
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

// The folder that holds cam0/, cam1/ and imu0/: ASL/mav0, or ASL itself.
Expected<fs::path> mav0Of(const fs::path& asl_folder) {
  if (fs::is_directory(asl_folder / "mav0")) return asl_folder / "mav0";
  if (fs::is_directory(asl_folder / "cam0")) return asl_folder;
  return makeError(asl_folder.string(), ": not an EuRoC ASL folder (no mav0/ inside)");
}

// Stereo pairs: stamps present in both cameras (the rig is hardware-triggered, so the stamps
// of a pair are equal).
Expected<std::vector<StereoRow>> stereoPairs(const fs::path& mav0, ConversionSummary* summary) {
  auto left = presentImages(mav0 / "cam0", &summary->skipped_missing_image);
  if (!left) return left.error();
  auto right = presentImages(mav0 / "cam1", &summary->skipped_missing_image);
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
  summary->skipped_unpaired = static_cast<int64_t>(left->size() + right->size() - 2 * pairs.size());
  return pairs;
}

// The ground truth of the options' file, or of the folder's estimate when it has one.
Expected<std::vector<StampedPose>> groundTruthOf(const fs::path& mav0, fs::path gt_file,
                                                 ConversionSummary* summary) {
  if (gt_file.empty() && fs::is_regular_file(mav0 / "state_groundtruth_estimate0/data.csv")) {
    gt_file = mav0 / "state_groundtruth_estimate0/data.csv";
  }
  if (gt_file.empty()) return std::vector<StampedPose>{};
  auto gt = readEurocGroundTruth(gt_file);
  if (!gt) return gt.error();
  summary->ground_truth = gt_file.string();
  return std::move(*gt);
}

// A stereo pair's message: both image files, checked against the calibration's size.
Expected<stereo_image_t> stereoMessage(const StereoRow& row, int64_t utime,
                                       const core::StereoCalibration& calibration,
                                       messages::ImageEncoding encoding) {
  evermap::stereo_image_t msg;
  msg.utime = utime;
  msg.rectified = 0;
  for (auto [file, cam, slot] : {std::tuple{&row.left, &calibration.left, &msg.left},
                                 std::tuple{&row.right, &calibration.right, &msg.right}}) {
    auto image = messages::imageMsgFromFile(*file, utime, encoding);
    if (!image) return image.error();
    if (image->width != cam->width || image->height != cam->height) {
      return makeError(file->string(), ": image is ", image->width, "x", image->height,
                       ", the calibration says ", cam->width, "x", cam->height);
    }
    *slot = std::move(*image);
  }
  return msg;
}

}  // namespace

Expected<ConversionSummary> convertEurocToLcm(const fs::path& asl_folder, const fs::path& output,
                                              const EurocToLcmOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto mav0_folder = mav0Of(asl_folder);
  if (!mav0_folder) return mav0_folder.error();
  const fs::path& mav0 = *mav0_folder;
  ConversionSummary summary;
  auto calibration =
      readEurocStereoCalibration(mav0 / "cam0/sensor.yaml", mav0 / "cam1/sensor.yaml");
  if (!calibration) return calibration.error();
  auto imu = readEurocImu(mav0 / "imu0/data.csv");
  if (!imu) return imu.error();
  auto pairs = stereoPairs(mav0, &summary);
  if (!pairs) return pairs.error();
  auto truth = groundTruthOf(mav0, options.ground_truth, &summary);
  if (!truth) return truth.error();

  std::vector<PendingEvent> events;
  events.reserve(imu->size() + truth->size() + pairs->size());
  for (size_t i = 0; i < imu->size(); ++i) {
    events.push_back({(*imu)[i].utime, EventKind::kImu, i});
  }
  for (size_t i = 0; i < truth->size(); ++i) {
    events.push_back({messages::utimeFromNs((*truth)[i].t_ns), EventKind::kGroundTruth, i});
  }
  for (size_t i = 0; i < pairs->size(); ++i) {
    events.push_back({messages::utimeFromNs((*pairs)[i].t_ns), EventKind::kStereo, i});
  }
  if (pairs->empty()) return makeError(mav0.string(), ": no stereo pair with both image files");
  detail::sortByTime(&events);

  channels::CalibrationRepeat calib_repeat;
  auto writer = detail::openStereoLog(output, calib_repeat, *calibration, events.front().utime);
  if (!writer) return writer.error();
  return detail::writeEvents(*writer, events, summary, [&](const PendingEvent& e) -> Status {
    switch (e.kind) {
      case EventKind::kImu:
        return writer->write(channels::kImu, e.utime, imu::toLcm((*imu)[e.index]));
      case EventKind::kGroundTruth:
        return writer->write(
            channels::kGroundTruth, e.utime,
            messages::toMsg(e.utime, core::UncertainPose{(*truth)[e.index].world_T_body}));
      case EventKind::kStereo:
        break;
    }
    auto msg = stereoMessage((*pairs)[e.index], e.utime, *calibration, options.encoding);
    if (!msg) return msg.error();
    Status s = detail::writeCalibrationIfDue(*writer, calib_repeat, *calibration, e.utime);
    if (s) s = writer->write(channels::kStereo, e.utime, *msg);
    return s;
  });
}

}  // namespace evermap::datasets
