#pragma once
// STEREO_CALIB (or RGBD_CALIB) for the mapper (docs/contracts.md): calibration is state, latched.
// The mapper takes the rectified left camera's body_T_cam from it, since VO deltas are camera
// motions; until the first valid one, VO_DELTA cannot be used (the caller refuses it, counted).
// Sources repeat the message every second: the same bytes, time stamp aside, change nothing. A
// calibration that does not validate is refused and the camera in use, if any, stays.
// Used by LcmNode (mapper-proc) and the offline runner of the whole system (evermap-slam-run).

#include <cstdint>
#include <functional>
#include <vector>

#include "core/common/expected.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

struct CalibrationLatchCounts {
  int64_t undecodable = 0;
  int64_t refused = 0;         // decoded, but did not validate or rectify
  int64_t camera_changes = 0;  // distinct valid calibrations applied
};

class CalibrationLatch {
 public:
  // Where a new camera mounting goes (Mapper::setCameraMounting, Localizer::setCameraMounting).
  using SetMounting = std::function<void(const core::SE3d& body_T_cam)>;
  // One STEREO_CALIB event's bytes; a new valid calibration goes to `mapper`. An error (one
  // line, naming the message) for one that is refused.
  Status handle(const void* data, int64_t size, Mapper& mapper);
  Status handle(const void* data, int64_t size, const SetMounting& set);
  // The same for one RGBD_CALIB event (an RGB-D camera: body_T_cam of its camera). The latch
  // holds one camera, whichever kind sent it last.
  Status handleRgbd(const void* data, int64_t size, Mapper& mapper);
  Status handleRgbd(const void* data, int64_t size, const SetMounting& set);
  bool haveCamera() const { return have_camera_; }
  const CalibrationLatchCounts& counts() const { return counts_; }

 private:
  // Both: the repeat test, decoding, `mounting` (the message → body_T_cam), the counts.
  template <typename Msg, typename Mounting>
  Status latch(const void* data, int64_t size, const char* channel, const SetMounting& set,
               Mounting mounting);

  bool have_camera_ = false;
  std::vector<uint8_t> last_;  // the last applied message, hash and utime zeroed
  CalibrationLatchCounts counts_;
};

}  // namespace evermap::mapper
