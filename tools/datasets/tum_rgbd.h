#pragma once
// Readers for the TUM RGB-D benchmark layout (Sturm, Engelhard, Endres, Burgard & Cremers,
// "A benchmark for the evaluation of RGB-D SLAM systems", IROS 2012):
//
//   rgb.txt, depth.txt     "timestamp filename" per line ('#' comments), seconds
//   rgb/*.png              color (8-bit, 3 channels) or already gray (8-bit, 1 channel)
//   depth/*.png            16-bit, one channel, registered to the color camera;
//                          metres = value / 5000, 0 = no depth
//   groundtruth.txt        "timestamp tx ty tz qx qy qz qw": the color camera's optical centre
//                          in the motion-capture frame
//   accelerometer.txt      "timestamp ax ay az", m/s^2 (the Kinect's accelerometer)
//
// Color and depth are not synchronised; they are paired by associateByTime(), the rule of
// TUM's associate.py.

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "tools/datasets/euroc.h"

namespace evermap::datasets {

// One line of rgb.txt or depth.txt.
struct TumImageEntry {
  int64_t t_ns = 0;
  std::filesystem::path file;  // relative to the sequence folder
};

struct AccelSample {
  int64_t t_ns = 0;
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

// "timestamp filename" lines. Errors name file:line (a stamp that is not a number, a missing
// file name, stamps not increasing).
Expected<std::vector<TumImageEntry>> readTumImageList(const std::filesystem::path& file);
// "timestamp ax ay az" lines; errors name file:line.
Expected<std::vector<AccelSample>> readTumAccelerometer(const std::filesystem::path& file);

// TUM's associate.py: every pair (a, b) with |t_a - t_b| < max_difference_ns is a candidate;
// candidates are taken in order of increasing |t_a - t_b|, each stamp at most once. The
// result, (index in a, index in b), is in increasing order of a. Both lists must be sorted.
std::vector<std::pair<size_t, size_t>> associateByTime(const std::vector<int64_t>& a_ns,
                                                       const std::vector<int64_t>& b_ns,
                                                       int64_t max_difference_ns);

// The calibrations TUM publishes for its Kinects (vision.in.tum.de/data/datasets/rgbd-dataset/
// file_formats, "Intrinsic Camera Calibration of the Kinect"), 640x480, body = the color camera:
//   "freiburg1"   fx 517.3 fy 516.5 cx 318.6 cy 255.3, radtan 0.2624 -0.9531 -0.0054 0.0026 1.1633
//   "freiburg2"   fx 520.9 fy 521.0 cx 325.1 cy 249.7, radtan 0.2312 -0.7849 -0.0033 -0.0001 0.9172
//   "freiburg3"   fx 535.4 fy 539.2 cx 320.1 cy 247.6, no distortion (images undistorted)
//   "ros-default" fx 525.0 fy 525.0 cx 319.5 cy 239.5, no distortion (TUM's advice for the
//                 registered depth when the camera is unknown)
Expected<core::CameraCalibration> tumCalibration(const std::string& name);
// The preset for a sequence folder: "freiburgN"/"frN" in its name, else "ros-default".
std::string tumCalibrationNameFor(const std::filesystem::path& sequence);

struct TumRgbdSequence {
  std::filesystem::path folder;
  std::vector<TumImageEntry> color;  // rgb.txt
  std::vector<TumImageEntry> depth;  // depth.txt
  // (index in color, index in depth) of the associated frames, in time order.
  std::vector<std::pair<size_t, size_t>> frames;
  int64_t unassociated_color = 0;  // color images with no depth within the limit
  int64_t unassociated_depth = 0;
  std::vector<StampedPose> ground_truth;   // empty when groundtruth.txt is absent
  std::vector<AccelSample> accelerometer;  // empty when accelerometer.txt is absent
};

struct TumRgbdOptions {
  double max_difference_s = 0.02;  // associate.py's default

  Status validate() const;
};

// Reads the lists and associates them; rgb.txt and depth.txt are required, the other two
// optional. Errors name the file and line; a sequence with no associated frame is an error.
Expected<TumRgbdSequence> readTumRgbdSequence(const std::filesystem::path& folder,
                                              const TumRgbdOptions& options = {});

}  // namespace evermap::datasets
