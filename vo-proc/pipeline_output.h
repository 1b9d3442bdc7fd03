#pragma once
// What VoPipeline (vo_pipeline.h) makes of one frame: its VO_DELTA, its KEYFRAME when it is a
// new keyframe, VO_CALIB when due, and the details.

#include <optional>
#include <vector>

#include <evermap/keyframe_t.hpp>
#include <evermap/stereo_calib_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "vo-proc/stereo_odometry.h"

namespace evermap::vo {

struct PipelineOutput {
  evermap::vo_delta_t delta;
  std::optional<evermap::keyframe_t> keyframe;
  // VO_CALIB: the rectified calibration VO measures with, its right cx = left cx + the
  // disparity offset self-calibration decided on (stereo only): on the frame it decided, then
  // once per channels::kCalibrationPeriodS of frames (state, like STEREO_CALIB).
  std::optional<evermap::stereo_calib_t> calibration;
  FrameResult result;  // the details (message, counts)
};
// What one input releases: one output, none while the start-up is held, or several when the
// hold ends (oldest first).
using PipelineOutputs = std::vector<PipelineOutput>;

}  // namespace evermap::vo
