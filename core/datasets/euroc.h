#pragma once
// Readers for the EuRoC ASL folder layout (mav0/cam0, cam1, imu0) and its ground-truth files.
// Burri et al., "The EuRoC micro aerial vehicle datasets", IJRR 2016.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::datasets {

struct ImuSample {
  int64_t t_ns = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

struct ImageEntry {
  int64_t t_ns = 0;
  std::string filename;  // relative to the camera's data/ folder
};

struct StampedPose {
  int64_t t_ns = 0;
  core::SE3d world_T_body;
};

// imu0/data.csv: "t[ns], gyro xyz [rad/s], accel xyz [m/s^2]".
Expected<std::vector<ImuSample>> readEurocImu(const std::filesystem::path& csv);
// camN/data.csv: "t[ns], filename".
Expected<std::vector<ImageEntry>> readEurocImages(const std::filesystem::path& csv);
// Ground truth: EuRoC state_groundtruth_estimate0/data.csv layout
// "t[ns], p xyz, q wxyz, ..." (extra columns ignored), or TUM text "t[s] x y z qx qy qz qw"
// when the file name ends in .txt.
Expected<std::vector<StampedPose>> readEurocGroundTruth(const std::filesystem::path& file);

// Splits one CSV/whitespace line into numbers; returns false on a field that is not a number.
bool parseNumbers(const std::string& line, char separator, std::vector<double>* out);

}  // namespace evermap::datasets
