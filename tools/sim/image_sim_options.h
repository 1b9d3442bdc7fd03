#pragma once
// Settings of the image-level simulator (evermap-sim-render), in the same `key = value` files as
// the measurement-level simulator (config/sim-*.conf, sim_options.h). A file holds:
//   - the measurement simulator's keys, read by loadSimOptions: seed, building.*, patrol.*,
//     elevator.*, camera.* (mounting and rectified intrinsics), wheel.*, imu.* (the image
//     simulator writes IMU for the whole session at imu.rate_hz; imu.margin_s is unused),
//     ground_truth.rate_hz, vo.passerby_* (when passers-by walk through the view; the other
//     vo.* and oracle.* keys are accepted and unused: VO runs on the images);
//   - its own keys, below: render.*, world.*, lighting.*, passerby.*, rgbd.* (the depth
//     sensor of render.camera = rgbd: depth_sensor.h's DepthSensorOptions, same names).
// Failure switches: building.dark_room_fraction (lights off), building.blank_wall_fraction with
// world.blank_radius_m (featureless walls, floor and ceiling around those junctions),
// vo.passerby_rate_per_hour (passers-by), lighting.* (per session camera response), the
// elevator.* ride profile (rides happen whenever the patrol visits another floor).

#include <cstdint>
#include <filesystem>
#include <string>

#include "core/common/key_value_file.h"
#include "core/messages/convert.h"
#include "tools/sim/depth_sensor.h"
#include "tools/sim/render_world.h"
#include "tools/sim/sim_options.h"
#include "tools/sim/stereo_renderer.h"
#include "tools/sim/textures.h"

namespace evermap::sim {

// What the robot's camera is: the rectified stereo pair of camera.* (STEREO, STEREO_CALIB), or
// an RGB-D camera (RGBD, RGBD_CALIB): the left camera's gray image and a Kinect-like depth
// image registered to it (rgbd.*, depth_sensor.h); camera.baseline_m is then unused.
enum class CameraMode { kStereo, kRgbd };

struct RenderSimOptions {
  CameraMode camera = CameraMode::kStereo;  // render.camera = stereo | rgbd
  int width = 752;                          // pixels (camera.cx, camera.cy must lie inside)
  int height = 480;
  double rate_hz = 20.0;          // stereo pairs per second
  double noise_sigma_gray = 2.0;  // sensor noise, gray levels
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  std::string posters = "auto";  // auto: $EVERMAP_DATA or ../shared/data; none; or a folder
  int session = 0;               // which session of the patrol plan to render
  double max_duration_s = 0.0;   // render at most this much of the session (0: all)
  double door_margin_s = 2.0;    // the cab door is closed from this long before a ride to after
  WorldOptions world;
  TextureOptions textures;
  DepthSensorOptions depth;  // rgbd.*, read in both modes, used in rgbd

  Status validate() const;
};

// Camera response per session: session k uses base * (1 + jitter * x), x uniform in [-1, 1]
// per session for gain and gamma, base + jitter * x for the offset; session 0 uses the base.
struct LightingOptions {
  Lighting base;
  double gain_jitter = 0.0;
  double offset_jitter_gray = 0.0;
  double gamma_jitter = 0.0;

  Status validate() const;
  Lighting forSession(int session, uint64_t seed) const;
};

// Passers-by: during each vo.passerby_* interval one person (a textured upright rectangle)
// walks across the view at a distance drawn in [distance_min_m, distance_max_m] ahead.
struct PasserbyOptions {
  double distance_min_m = 0.7;
  double distance_max_m = 1.2;
  double width_m = 1.0;
  double height_m = 1.85;

  Status validate() const;
};

struct ImageSimOptions {
  SimOptions sim;
  RenderSimOptions render;
  LightingOptions lighting;
  PasserbyOptions passerby;
  std::filesystem::path config_folder;  // where relative folders are resolved

  // The measurement simulator's keys (SimOptions), then this simulator's own.
  void declareOptions(OptionList& o);
  Status validate() const;
  PinholeCamera camera() const;
  // The poster folder `render.posters` names (empty: procedural posters).
  std::filesystem::path posterFolder() const;
  // Every setting as `key = value  # unit` lines (the measurement keys first).
  std::string toConfigText() const;
};

// Errors name the file and line ("sim-image.conf:12: render.width: ..."), one line.
Expected<ImageSimOptions> loadImageSimOptions(const KeyValueFile& file);

}  // namespace evermap::sim
