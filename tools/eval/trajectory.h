#pragma once
// Trajectories for evaluation: stamped poses world_T_body read from, and written to, the
// three common text formats.
//
//  - TUM (Sturm et al., IROS 2012): "t[s] x y z qx qy qz qw" per line, '#' comments.
//  - KITTI odometry (Geiger et al., CVPR 2012): 12 numbers per line, the row-major 3x4
//    matrix [R | t] of world_T_cam0. Stamps come from a separate times file (one time in
//    seconds per line, as the data set's times.txt); without one, pose k has stamp k seconds,
//    so two KITTI files of the same sequence associate frame by frame.
//  - EuRoC ground-truth CSV: "t[ns], p xyz, q wxyz, ..." (Burri et al., IJRR 2016).
// TUM and EuRoC are read by tools/datasets/euroc.h; this file adds KITTI, format guessing and
// the checks every metric relies on (non-empty, finite, strictly increasing stamps).

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "tools/datasets/euroc.h"

namespace evermap::eval {

using datasets::StampedPose;

enum class TrajectoryFormat { kTum, kKitti, kEuroc };

// "tum", "kitti", "euroc".
const char* toString(TrajectoryFormat format);
Expected<TrajectoryFormat> parseTrajectoryFormat(std::string_view name);

// A trajectory: poses world_T_body with strictly increasing stamps. `source` names where it
// came from (the file), so that every error about it can say which input was wrong.
struct Trajectory {
  std::string source;
  std::vector<StampedPose> poses;

  size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  // Sum of the distances between consecutive positions, metres.
  double pathLengthM() const;
};

// The checks the metrics rely on: at least one pose, finite translations, strictly increasing
// stamps. The error names `trajectory.source` and the offending pose.
Status validate(const Trajectory& trajectory);

// Guesses the format of a file: ".csv" is EuRoC; otherwise the first data line decides
// (8 numbers: TUM, 12 numbers: KITTI, a comma: EuRoC).
Expected<TrajectoryFormat> guessTrajectoryFormat(const std::filesystem::path& file);

// Readers; every result has passed validate().
Expected<Trajectory> readTum(const std::filesystem::path& file);
Expected<Trajectory> readEuroc(const std::filesystem::path& file);
// `times` may be empty (stamps = line index in seconds); otherwise it must hold exactly one
// stamp per pose line.
Expected<Trajectory> readKitti(const std::filesystem::path& poses,
                               const std::filesystem::path& times = {});
// Dispatches on `format`; `kitti_times` is used by the KITTI reader only.
Expected<Trajectory> readTrajectory(const std::filesystem::path& file, TrajectoryFormat format,
                                    const std::filesystem::path& kitti_times = {});

// Writes TUM text with nanosecond-exact stamps (9 decimals), through a temporary file and a
// rename.
Status writeTum(const Trajectory& trajectory, const std::filesystem::path& file);

}  // namespace evermap::eval
