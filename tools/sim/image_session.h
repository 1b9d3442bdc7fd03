#pragma once
// One image-level session (DESIGN.md section 8): the robot patrols the building of the
// measurement-level simulator (same building, patrol plan and elevator rides for the same seed
// and keys), and this produces what its sensors would publish, in time order:
//   STEREO_CALIB  stereo_calib_t before the first pair and again every second (rectified
//                 pinholes, body_T_cam of camera.*; docs/contracts.md)
//   IMU           imu_t at imu.rate_hz for the whole session (measureImu: gravity, accelerometer
//                 bias per session, white noise)
//   GROUND_TRUTH  pose_t world_T_body at ground_truth.rate_hz (floor and session set)
//   WHEEL_ODOM    wheel_odom_t at wheel.rate_hz (WheelModel: noise and slips)
//   STEREO        stereo_image_t at render.rate_hz, rectified, rendered (stereo_renderer.h)
// With render.camera = rgbd, RGBD_CALIB (rgbd_calib_t: the left camera, same repeat) and RGBD
// (rgbd_image_t: the left camera's gray image and a Kinect-like depth image from the same ray
// cast, depth_sensor.h) take the places of STEREO_CALIB and STEREO; the rest is unchanged.
// Ties at one instant go out in that order. Random streams derive from the run's seed with the
// stream numbers of session_generator.cpp for what both simulators share (wheel 3000, IMU
// 5000, passers-by 7000, slips 8000, + session), so passers-by and slips happen at the same
// times in both; 10000 + session renders the sensor noise, 10100 the textures, 10200 the
// painting of the walls, 10500 + session the depth sensor.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera/calibration.h"
#include "core/common/progress.h"
#include "core/messages/channels.h"
#include "core/common/expected.h"
#include "tools/sim/depth_sensor.h"
#include "tools/sim/image_sim_options.h"
#include "tools/sim/message_sink.h"
#include "tools/sim/render_world.h"
#include "tools/sim/run.h"
#include "tools/sim/sensors.h"
#include "tools/sim/stereo_renderer.h"

namespace evermap::sim {

// What the camera faces at one frame (for the summary and for tests).
struct FrameFacts {
  int floor = -1;
  bool dark_room = false;   // the camera is in a room with the lights off
  bool blank_zone = false;  // the camera is in a featureless zone
  bool passerby = false;    // a passer-by is in front of the camera
  bool closed_cab = false;  // inside the elevator cab with its door closed
};

struct ImageSessionSummary {
  int session = 0;
  double duration_s = 0.0;
  double distance_m = 0.0;  // driven in the rendered part
  int rides = 0;            // elevator rides in the rendered part
  std::vector<int> floors_visited;
  int64_t frames = 0, frames_dark_room = 0, frames_blank_zone = 0, frames_passerby = 0,
          frames_closed_cab = 0;
  std::map<std::string, ChannelCount> channels;
  std::vector<std::pair<int64_t, FrameFacts>> frame_facts;  // per stereo frame, by utime
  double render_s = 0.0;  // wall time spent rendering (a measurement, not an input)
  double encode_s = 0.0;  // wall time spent encoding images

  std::string text() const;  // figures, one per line
};

class ImageSimulator {
 public:
  // `progress` (if set) hears of each stage of the setting up (the textures take seconds).
  static Expected<std::unique_ptr<ImageSimulator>> create(const ImageSimOptions& options,
                                                          ProgressReporter* progress = nullptr);

  const ImageSimOptions& options() const { return options_; }
  const Building& building() const { return plan_.building(); }
  const SessionPlan& session() const { return session_; }
  const RenderWorld& world() const { return world_; }
  const TextureLibrary& textures() const { return *textures_; }
  int64_t startUtime() const;
  int64_t endUtime() const;  // of the rendered part
  core::StereoCalibration calibration() const;

  // The stereo pair at `utime` (startUtime() <= utime <= endUtime()).
  FrameFacts renderPair(int64_t utime, cv::Mat* left, cv::Mat* right);
  // The RGB-D frame at `utime`: the left camera's gray image, its depth measured by the depth
  // sensor (CV_16UC1 in rgbd.unit_m, 0 = none) and, if `truth` is given, the exact depth
  // (CV_32FC1, metres). Consecutive calls draw the sensor's noise from one stream.
  FrameFacts renderRgbd(int64_t utime, cv::Mat* gray, cv::Mat* depth, cv::Mat* truth = nullptr);

  // Writes the session into `sink`. `progress` (if set) is called after every stereo frame
  // with the fraction done; returning false stops early (the summary covers what was written).
  Expected<ImageSessionSummary> run(MessageSink& sink,
                                    const std::function<bool(double)>& progress = {});

 private:
  ImageSimulator(const ImageSimOptions& options, RunPlan plan);
  FrameFacts facts(int64_t utime, const BodyState& state) const;
  // The summary's figures known before the run (session, duration, distance, rides).
  ImageSessionSummary summaryHead() const;
  // The summary's figures of a run stopped after the frame at `utime`.
  void stoppedAt(int64_t utime, ImageSessionSummary* summary) const;
  // Renders the camera frame at `utime` and writes it (after the calibration when due) into
  // `sink`; counts it in `summary`. Errors: the image encoding.
  Status writeCameraFrame(MessageSink& sink, int64_t utime, const core::StereoCalibration& calib,
                          channels::CalibrationRepeat& calib_repeat, ImageSessionSummary* summary);
  std::vector<Occluder> passersBy(int64_t utime) const;

  ImageSimOptions options_;
  RunPlan plan_;
  SessionPlan session_;
  std::unique_ptr<TextureLibrary> textures_;
  RenderWorld world_;
  Intervals passers_;
  std::unique_ptr<ImageRenderer> renderer_;
  std::unique_ptr<DepthSensor> depth_sensor_;
  cv::Mat depth_truth_;
  cv::Mat frame_left_, frame_right_, frame_depth_;  // the frame run() renders, reused
};

// Writes the session as an LCM log at `output` (temporary file, renamed when complete).
Expected<ImageSessionSummary> writeImageSessionLog(
    ImageSimulator& simulator, const std::filesystem::path& output,
    const std::function<bool(double)>& progress = {});

}  // namespace evermap::sim
