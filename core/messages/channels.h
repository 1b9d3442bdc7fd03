#pragma once
// LCM channel names used by evermap (DESIGN.md section 1). One place, so a rename is one edit.

#include <cstdint>

namespace evermap::channels {

inline constexpr const char* kStereo = "STEREO";             // stereo_image_t
inline constexpr const char* kStereoCalib = "STEREO_CALIB";  // stereo_calib_t
inline constexpr const char* kRgbd = "RGBD";                 // rgbd_image_t (calibration inside)
inline constexpr const char* kRgbdCalib = "RGBD_CALIB";      // rgbd_calib_t (for the mapper)
inline constexpr const char* kAccel = "ACCEL";               // accel_t (no gyroscope: Kinect)
inline constexpr const char* kImu = "IMU";                   // imu_t
inline constexpr const char* kWheelOdom = "WHEEL_ODOM";      // wheel_odom_t
inline constexpr const char* kGroundTruth = "GROUND_TRUTH";  // pose_t
inline constexpr const char* kVoDelta = "VO_DELTA";          // vo_delta_t
inline constexpr const char* kKeyframe = "KEYFRAME";         // keyframe_t
inline constexpr const char* kVoCalib = "VO_CALIB";  // stereo_calib_t: as VO self-calibrated it
inline constexpr const char* kKeyframeRequest = "KEYFRAME_REQUEST";  // keyframe_request_t
inline constexpr const char* kKeyframePart = "KEYFRAME_PART";        // keyframe_part_t
inline constexpr const char* kAttitude = "ATTITUDE";                 // attitude_t
inline constexpr const char* kFloor = "FLOOR";                       // floor_t
inline constexpr const char* kNodeAdded = "NODE_ADDED";              // node_added_t
inline constexpr const char* kRegisterRequest = "REGISTER_REQUEST";  // register_request_t
inline constexpr const char* kRegisterResult = "REGISTER_RESULT";    // register_result_t
inline constexpr const char* kPose = "POSE";                         // pose_t
inline constexpr const char* kMapGraph = "MAP_GRAPH";                // map_graph_t
inline constexpr const char* kLocalization = "LOCALIZATION";         // localization_t
inline constexpr const char* kMapperStats = "MAPPER_STATS";          // mapper_stats_t
inline constexpr const char* kDeputyStatus = "DEPUTY_STATUS";        // deputy_status_t
inline constexpr const char* kDeputyOrder = "DEPUTY_ORDER";          // deputy_order_t
inline constexpr const char* kDeputyOutput = "DEPUTY_OUTPUT";        // deputy_output_t
inline constexpr const char* kInputStats = "INPUT_STATS";            // input_stats_t

// Calibration is state, not an event (docs/contracts.md): every source of STEREO sends
// STEREO_CALIB before its first frame and again before the first frame of every period, so a
// process that starts or restarts mid-stream has the camera within one period.
inline constexpr double kCalibrationPeriodS = 1.0;

// Whether a source repeats its STEREO_CALIB before the frame at `utime`.
class CalibrationRepeat {
 public:
  bool due(int64_t utime) {
    if (next_utime_ >= 0 && utime < next_utime_) return false;
    next_utime_ = utime + static_cast<int64_t>(kCalibrationPeriodS * 1e6);
    return true;
  }

 private:
  int64_t next_utime_ = -1;
};

}  // namespace evermap::channels
