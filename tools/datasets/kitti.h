#pragma once
// Readers for the KITTI odometry layout: sequences/NN/{image_0, image_1, calib.txt, times.txt}
// and poses/NN.txt. Geiger, Lenz & Urtasun, "Are we ready for autonomous driving?", CVPR 2012.
//
// The images are already rectified: P0 and P1 (3x4 projection matrices of the left and right
// gray cameras) share K, and P1 = K [I | (-b, 0, 0)], so baseline = -P1(0,3) / P1(0,0).
// Poses are of camera 0 in the frame of camera 0 at the first frame (world_T_cam0).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::datasets {

using Mat34 = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

struct KittiProjections {
  Mat34 P0 = Mat34::Zero();  // left gray camera
  Mat34 P1 = Mat34::Zero();  // right gray camera
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

// Where a sequence's files are, and what is not in the folder itself.
struct KittiSequenceOptions {
  // Frame rate (Hz) for a sequence without times.txt: frame i at i / rate_hz seconds, the
  // frames being 000000.png up to the highest number in the left folder. When > 0 it is used
  // even if times.txt exists. 0: times.txt is required (KITTI records at about 10 Hz).
  double rate_hz = 0.0;
  // Image folders, relative to the sequence (or absolute). Empty: image_0 / image_1 (KITTI's
  // layout), else image_l / image_r (the layout of copies such as kitti-stereo-clip).
  std::filesystem::path left_folder;
  std::filesystem::path right_folder;
  // Ground-truth poses (KITTI format, one line per frame). Empty: <sequence>/poses.txt when
  // it exists, else no ground truth.
  std::filesystem::path poses;

  Status validate() const;
};

// The frames of a stereo sequence folder: image_0/ + image_1/ (or the options' folders),
// calib.txt, times.txt (or a rate), poses.txt (optional).
struct KittiSequence {
  std::filesystem::path folder, left_dir, right_dir, calib_file, poses_file;
  KittiProjections projections;
  std::vector<int64_t> times_ns;  // every frame number, from times.txt or the rate
  std::vector<core::SE3d> poses;  // world_T_cam0 per frame number; empty without ground truth
  std::vector<size_t> frames;     // frame numbers with both images, increasing
  int64_t skipped_missing_image = 0;

  std::filesystem::path leftImage(size_t frame) const;  // left_dir / NNNNNN.png
  std::filesystem::path rightImage(size_t frame) const;
};

// Errors name the file or folder: no left or no right images (a monocular copy), no times.txt
// and no rate, a calibration or poses file that does not parse, more or fewer poses than
// frames, no frame with both images.
Expected<KittiSequence> readKittiSequence(const std::filesystem::path& folder,
                                          const KittiSequenceOptions& options);

}  // namespace evermap::datasets
