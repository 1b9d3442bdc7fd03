#include "tools/slam-run/session_processes.h"

#include "core/common/clocks.h"
#include "core/messages/channels.h"

namespace evermap::slam_run {

Expected<vo::PipelineOutputs> SessionProcesses::runVo(const detail::ReadEvent& e) {
  const void* data = e.data.data();
  const auto size = static_cast<int64_t>(e.data.size());
  if (e.channel == channels::kRgbd) {
    if (e.rgbd_frame) return vo.handleRgbdFrame(e.stereo_utime, *e.rgbd_frame);
    return vo.handleRgbdBytes(data, size);
  }
  if (e.frame) return vo.handleFrame(e.stereo_utime, *e.frame);
  return vo.handleStereoBytes(data, size);
}

void deliverFrame(const vo::PipelineOutput& out, bool have_camera, loopclose::LoopCloser& closer,
                  mapper::MapInputs& map, const std::function<void(const std::string&)>& error,
                  double* loopclose_s, double* map_s) {
  if (out.keyframe) {
    const auto t0 = SteadyClock::now();
    if (Status s = closer.addKeyframe(*out.keyframe); !s) error("KEYFRAME: " + s.error().message);
    *loopclose_s += secondsSince(t0);
  }
  const auto t0 = SteadyClock::now();
  if (!have_camera) {
    error("VO_DELTA before STEREO_CALIB or RGBD_CALIB");
  } else if (Status s = map.onVo(out.delta); !s) {
    error("VO_DELTA: " + s.error().message);
  }
  *map_s += secondsSince(t0);
}

}  // namespace evermap::slam_run
