#include "tools/vo-run/sequence_run.h"

#include <time.h>

#include <cmath>
#include <map>
#include <numbers>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/camera/calibration.h"
#include "core/common/clocks.h"
#include "core/common/percentile.h"
#include "core/messages/convert.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"
#include "tools/vo-run/offline_runner.h"
#include "tools/vo-run/vo_trajectory.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::vo {

namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

// The error figures of the posed frames (at least 3) against their ground truth.
Status measureErrors(SequenceRun* r) {
  SequenceRun& run = *r;
  const std::vector<double> along = eval::cumulativeDistances(run.gt);
  run.path_length_m = along.back();
  const core::SE3d end = run.gt.back().inverse() * run.est.back();
  run.end_error_m = (run.est.back().translation() - run.gt.back().translation()).norm();
  run.end_error_percent = 100.0 * run.end_error_m / std::max(run.path_length_m, 1e-9);
  run.end_rotation_deg = core::rotationAngle(end.so3()) * kDeg;

  std::vector<core::Vec3> src, dst;
  for (size_t k = 0; k < run.est.size(); ++k) {
    src.push_back(run.est[k].translation());
    dst.push_back(run.gt[k].translation());
  }
  auto align = eval::umeyama(src, dst, false);
  if (!align) return align.error();
  std::vector<core::SE3d> aligned;
  for (const core::SE3d& p : run.est) aligned.push_back(align->gt_S_est * p);
  auto ate = eval::computeAte(run.gt, aligned);
  if (!ate) return ate.error();
  run.ate_rmse_m = ate->translation_m.rmse;
  auto rpe = eval::computeRpe(run.gt, run.est, eval::RpeOptions{});
  if (!rpe) return rpe.error();
  const double mean_step = run.path_length_m / static_cast<double>(run.gt.size() - 1);
  run.rpe_percent = 100.0 * rpe->translation_m.mean / std::max(mean_step, 1e-9);
  run.rpe_deg = rpe->rotation_deg.mean;
  return Ok{};
}

}  // namespace

Status SequenceRunOptions::validate() const {
  if (Status s = odometry.validate(); !s) return s;
  return sequence.validate();
}

std::string SequenceRun::report() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << frames.size() << " frames, " << posed << " posed, " << keyframes << " keyframes, "
    << mean_inliers << " inliers per registered frame\n"
    << "path " << path_length_m << " m; end error " << end_error_m << " m (" << end_error_percent
    << " %), " << end_rotation_deg << " deg; ATE " << ate_rmse_m << " m RMSE; RPE per frame "
    << rpe_percent << " %, " << rpe_deg << " deg\n"
    << "per frame (thread CPU): median " << median_ms << " ms, p90 " << p90_ms << " ms, p99 "
    << p99_ms << " ms";
  return s.str();
}

Expected<SequenceRun> runKittiSequence(const std::filesystem::path& folder,
                                       const SequenceRunOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto seq = datasets::readKittiSequence(folder, options.sequence);
  if (!seq) return seq.error();
  if (seq->poses.empty()) return makeError(folder.string(), ": no ground truth (poses.txt)");
  const cv::Mat first =
      cv::imread(seq->leftImage(seq->frames.front()).string(), cv::IMREAD_GRAYSCALE);
  if (first.empty())
    return makeError(seq->leftImage(seq->frames.front()).string(), ": cannot read");
  auto from_file = datasets::kittiStereoCalibration(seq->projections, first.cols, first.rows,
                                                    seq->calib_file.string());
  if (!from_file) return from_file.error();
  auto calibration = core::withDisparityOffset(*from_file, options.disparity_offset_px);
  if (!calibration) return calibration.error();
  PipelineOptions pipeline_options;
  pipeline_options.odometry = options.odometry;
  pipeline_options.startup_hold_s = options.startup_hold_s;
  auto vo = VoPipeline::create(pipeline_options);
  if (!vo) return vo.error();
  if (Status s = vo->handleCalibration(messages::toMsg(*calibration, 0)); !s) return s.error();

  SequenceRun run;
  VoTrajectory chain;
  std::vector<double> inliers;
  std::map<int64_t, size_t> frame_at;  // utime -> folder frame
  auto take = [&](const PipelineOutput& out) {
    FrameResult r = out.result;
    if (r.keyframe_changed) ++run.keyframes;
    if (r.ok()) inliers.push_back(r.num_inliers);
    if (auto pose = chain.add(toMsg(r))) {
      ++run.posed;
      run.est.push_back(*pose);
      run.gt.push_back(seq->poses[frame_at.at(r.utime)]);
    }
    r.keyframe.reset();
    run.frames.push_back(std::move(r));
  };
  int read = 0;
  for (size_t i : seq->frames) {
    if (options.max_frames >= 0 && read >= options.max_frames) break;
    ++read;
    const cv::Mat left = cv::imread(seq->leftImage(i).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(seq->rightImage(i).string(), cv::IMREAD_GRAYSCALE);
    if (left.empty()) return makeError(seq->leftImage(i).string(), ": cannot read");
    if (right.empty()) return makeError(seq->rightImage(i).string(), ": cannot read");
    // +1: a sequence at rate R starts at utime 0, which is a valid first stamp.
    const int64_t utime = seq->times_ns[i] / 1000 + 1;
    frame_at[utime] = i;
    const double start = 1e3 * threadCpuSeconds();
    const PipelineOutputs outs =
        vo->handleFrame(utime, messages::StereoFrame{utime, /*rectified=*/true, left, right});
    run.cpu_ms.push_back(1e3 * threadCpuSeconds() - start);
    for (const PipelineOutput& out : outs) take(out);
  }
  for (const PipelineOutput& out : vo->flush()) take(out);
  if (run.est.size() < 3) {
    return makeError(folder.string(), ": only ", run.est.size(), " of ", run.frames.size(),
                     " frames have a pose");
  }
  if (Status s = measureErrors(&run); !s) return s.error();
  double sum = 0.0;
  for (double n : inliers) sum += n;
  run.mean_inliers = inliers.empty() ? 0.0 : sum / static_cast<double>(inliers.size());
  run.median_ms = percentile(run.cpu_ms, 0.5);
  run.p90_ms = percentile(run.cpu_ms, 0.9);
  run.p99_ms = percentile(run.cpu_ms, 0.99);
  return run;
}

}  // namespace evermap::vo
