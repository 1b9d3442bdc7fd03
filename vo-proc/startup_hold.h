#pragma once
// vo-proc's start-up hold (vo_pipeline.h): a stereo camera's first frames, with what odometry
// made of them, kept until self-calibration's first decision or until they span hold_s of
// message time. When that decision corrects the camera, the frames before it were measured
// with the wrong calibration, and VoPipeline processes them again with the corrected one
// before any is released: the first seconds of the trajectory carry the correction too (on
// the KITTI clip as given, the first 18 frames at the old calibration were 7.6 % short).
// Otherwise they are released as they were. After that, frames pass straight through.
//
// What it costs: VO's first outputs come late, by up to hold_s, once per camera; the mapper
// takes a late first frame after the wheels ran (mapper-proc/tracker.h). The held pairs'
// images are kept (about 0.9 MB per 1241x376 pair).

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "vo-proc/pipeline_output.h"

namespace evermap::vo {

class StartupHold {
 public:
  struct Frame {
    PipelineOutput output;  // what odometry made of it the first time
    cv::Mat left, right;    // the rectified pair; empty when the frame was not processed
    // Self-calibration decided on it.
    bool decided() const { return !output.result.calibration_message.empty(); }
    // ... and changed the camera.
    bool corrected() const { return output.result.calibration_changed; }
  };

  // Holding starts (a new camera); hold_s <= 0: never.
  void begin(double hold_s) {
    frames_.clear();
    hold_us_ = static_cast<int64_t>(hold_s * 1e6);
    active_ = hold_s > 0.0;
  }
  bool active() const { return active_; }
  void keep(Frame frame) { frames_.push_back(std::move(frame)); }
  // The hold ends with the last frame kept: it carried a decision, or the frames span hold_s.
  bool due() const {
    return active_ && !frames_.empty() &&
           (frames_.back().decided() ||
            frames_.back().output.result.utime - frames_.front().output.result.utime >= hold_us_);
  }
  // The frames held (oldest first); holding is over.
  std::vector<Frame> end() {
    active_ = false;
    std::vector<Frame> out;
    out.swap(frames_);
    return out;
  }

 private:
  std::vector<Frame> frames_;
  int64_t hold_us_ = 0;
  bool active_ = false;
};

}  // namespace evermap::vo
