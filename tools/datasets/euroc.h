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
#include "core/imu/imu_sample.h"

namespace evermap::datasets {

struct ImageEntry {
  int64_t t_ns = 0;
  std::string filename;  // relative to the camera's data/ folder
};

struct StampedPose {
  int64_t t_ns = 0;
  core::SE3d world_T_body;
};

// imu0/data.csv: "t[ns], gyro xyz [rad/s], accel xyz [m/s^2]"; each stamp rounded to the
// nearest microsecond (messages::utimeFromNs, as every data-set stamp that becomes a utime).
Expected<std::vector<imu::ImuSample>> readEurocImu(const std::filesystem::path& csv);
// camN/data.csv: "t[ns], filename".
Expected<std::vector<ImageEntry>> readEurocImages(const std::filesystem::path& csv);
// How a ground-truth file is laid out.
enum class PoseFileLayout {
  kByExtension,  // TUM when the file name ends in .txt, else EuRoC CSV
  kEurocCsv,     // "t[ns], p xyz, q wxyz, ..." (extra columns, e.g. v, bw, ba, ignored)
  kTum,          // "t[s] x y z qx qy qz qw", exactly 8 whitespace-separated numbers
};

// Ground truth: EuRoC state_groundtruth_estimate0/data.csv layout or TUM text (Sturm et al.,
// IROS 2012). Lines starting with '#' and blank lines are skipped. TUM stamps are read
// exactly to the nanosecond ("1403715274.30214"); exponent notation ("1.5e+01") is accepted
// at double precision. A malformed line, a non-finite value or a quaternion far from unit
// norm is an error naming file:line. Also the TUM reader of tools/eval.
Expected<std::vector<StampedPose>> readEurocGroundTruth(
    const std::filesystem::path& file, PoseFileLayout layout = PoseFileLayout::kByExtension);

// Seconds as text ("1403715274.30214", "0.000000e+00") to nanoseconds: exact for plain
// decimals, double precision with an exponent. False when the field is not a number.
bool parseSecondsToNs(const std::string& field, int64_t* out);

// Splits one CSV/whitespace line into numbers; returns false on a field that is not a number.
bool parseNumbers(const std::string& line, char separator, std::vector<double>* out);

}  // namespace evermap::datasets
