#pragma once
// The processes that start anew with each session of evermap-slam-run, mapping or localizing:
// vo-proc, imu-proc and elevator-proc, as their library classes.

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>

#include "core/imu/lcm_convert.h"
#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_stream.h"
#include "loopclose-proc/loop_closer.h"
#include "mapper-proc/map_inputs.h"
#include "tools/slam-run/event_stream.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::slam_run {

struct SessionProcesses {
  // What one IMU sample makes: imu-proc's ATTITUDE (when one is due) and elevator-proc's FLOOR
  // events.
  struct ImuOutputs {
    std::optional<attitude_t> attitude;
    std::vector<elevator::FloorEvent> floor_events;
  };

  SessionProcesses(vo::VoPipeline vo_pipeline, const imu::AttitudeFilterOptions& attitude_options,
                   double attitude_rate_hz,
                   const elevator::ElevatorTrackerOptions& elevator_options)
      : vo(std::move(vo_pipeline)),
        attitude(attitude_options, attitude_rate_hz),
        elevator(elevator_options) {}

  ImuOutputs onImu(const imu_t& msg) {
    ImuOutputs out;
    out.attitude = attitude.add(msg);
    if (out.attitude) latest_attitude = imu::fromLcm(*out.attitude);
    out.floor_events =
        elevator.add(imu::fromLcm(msg), latest_attitude ? &*latest_attitude : nullptr);
    return out;
  }

  // A STEREO or RGBD event through VO: decoded ahead by the reader; what did not decode as LCM
  // fails here as in vo-proc. The outputs it releases (vo_pipeline.h: the start-up hold).
  Expected<vo::PipelineOutputs> runVo(const detail::ReadEvent& e);

  vo::VoPipeline vo;
  imu::AttitudeStream attitude;
  elevator::ElevatorTracker elevator;
  std::optional<imu::Attitude> latest_attitude;
};

// A VO frame's outputs delivered: KEYFRAME to loopclose-proc, VO_DELTA to the mapper or the
// localizer (only once a calibration gave the camera's mounting), each timed into its
// seconds; a refused message to `error`, named by its channel.
void deliverFrame(const vo::PipelineOutput& out, bool have_camera, loopclose::LoopCloser& closer,
                  mapper::MapInputs& map, const std::function<void(const std::string&)>& error,
                  double* loopclose_s, double* map_s);

}  // namespace evermap::slam_run
