#pragma once
// Readers for the KITTI odometry layout: sequences/NN/{image_0, image_1, calib.txt, times.txt}
// and poses/NN.txt. Geiger, Lenz & Urtasun, "Are we ready for autonomous driving?", CVPR 2012.
//
// The images are already rectified: P0 and P1 (3x4 projection matrices of the left and right
// gray cameras) share K, and P1 = K [I | (-b, 0, 0)], so baseline = -P1(0,3) / P1(0,0).
// Poses are of camera 0 in the frame of camera 0 at the first frame (world_T_cam0).

#include <cstdint>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::datasets {

using Mat34 = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

struct KittiProjections {
  Mat34 P0;  // left gray camera
  Mat34 P1;  // right gray camera
};

// calib.txt in either form: the original labelled lines ("P0: 12 numbers", "P1: ...", other
// labels ignored) or bare lines of 12 numbers, the first two being P0 and P1.
Expected<KittiProjections> readKittiCalib(const std::filesystem::path& file);

// The rectified stereo calibration (rectified = true) of images of width x height: body = the
// left camera (body_T_left = identity), the right camera at +b along x. Refuses projections
// that are not a rectified pair (different K, P0 not [K | 0], P1 offset not along x, b <= 0).
Expected<core::StereoCalibration> kittiStereoCalibration(const KittiProjections& p, int width,
                                                         int height,
                                                         const std::string& what = "calib.txt");

// times.txt: one time in seconds per line, increasing; returned in nanoseconds.
Expected<std::vector<int64_t>> readKittiTimes(const std::filesystem::path& file);

// poses.txt: one row-major 3x4 [R | t] per line (world_T_cam0); rotations must be orthonormal
// to 1e-4 (the files carry 7 significant digits) and are projected onto SO(3).
Expected<std::vector<core::SE3d>> readKittiPoses(const std::filesystem::path& file);

}  // namespace evermap::datasets
