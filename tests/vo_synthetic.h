#pragma once
// A synthetic rectified stereo camera in a textured box room, for visual odometry tests with
// an exact ground truth. Each wall, the floor and the ceiling carry a real photograph (KITTI
// and EuRoC images from the shared data, slightly blurred against aliasing); images are ray
// cast per pixel (the ray through each pixel centre meets the box from inside at exactly one
// face), so occlusion and perspective are exact, and Gaussian noise of 1 gray level is added.
// This stands in for the image-level simulator (not written yet) on short sequences.
//
// Frames: world = the room (x right, y down, z forward, metres, centre at the origin);
// camera poses world_T_cam, the right camera at +baseline along the camera's x.

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera/calibration.h"
#include "core/camera/pinhole.h"
#include "core/camera/stereo_camera.h"
#include "core/geometry/se3.h"

namespace evermap::testing {

class TexturedRoom {
 public:
  // Half extents of the room (metres).
  static constexpr double kHalfX = 4.0, kHalfY = 1.5, kHalfZ = 4.0;

  // Loads six textures from `data_root`; ok() is false when they are missing.
  explicit TexturedRoom(const std::filesystem::path& data_root) {
    const std::filesystem::path kitti = data_root / "kitti07-mono-160/image_0";
    const std::filesystem::path euroc = data_root / "euroc-v101-micro/mav0/cam0/data";
    const std::array<std::filesystem::path, 6> files = {kitti / "000000.png",
                                                        kitti / "000050.png",
                                                        kitti / "000100.png",
                                                        kitti / "000150.png",
                                                        euroc / "1403715273262142976.png",
                                                        kitti / "000075.png"};
    for (size_t f = 0; f < files.size(); ++f) {
      cv::Mat image = cv::imread(files[f].string(), cv::IMREAD_GRAYSCALE);
      if (image.empty()) return;
      cv::Mat blurred;
      image.convertTo(blurred, CV_32F);
      cv::GaussianBlur(blurred, textures_[f], cv::Size(0, 0), 0.8);
    }
    ok_ = true;
  }

  bool ok() const { return ok_; }

  // The depth (z in the camera frame, metres) seen through pixel (u, v) of a camera at
  // world_T_cam: the truth for stereo depth.
  static double depthAt(const core::StereoCamera& camera, const core::SE3d& world_T_cam, double u,
                        double v) {
    const Eigen::Vector3d ray((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy(),
                              1.0);
    return exitDistance(world_T_cam.translation(), world_T_cam.rotationMatrix() * ray, nullptr);
  }

  // Renders the left and right images of a camera at world_T_cam (gray8, camera size).
  // `brightness` scales the texture (a dark room: 0.02); `blank` paints every face flat gray
  // (a blank wall). Noise: N(0, noise_sigma) per pixel from `rng`.
  void render(const core::StereoCamera& camera, const core::SE3d& world_T_cam, cv::Mat* left,
              cv::Mat* right, cv::RNG* rng, double brightness = 1.0, bool blank = false,
              double noise_sigma = 1.0) const {
    const core::SE3d cam_T_right(core::SO3d(), core::Vec3(camera.baselineM(), 0.0, 0.0));
    renderOne(camera, world_T_cam, left, rng, brightness, blank, noise_sigma);
    renderOne(camera, world_T_cam * cam_T_right, right, rng, brightness, blank, noise_sigma);
  }

 private:
  void renderOne(const core::StereoCamera& camera, const core::SE3d& world_T_cam, cv::Mat* out,
                 cv::RNG* rng, double brightness, bool blank, double noise_sigma) const {
    cv::Mat value_image(camera.height(), camera.width(), CV_32F);
    cv::Mat noise(camera.height(), camera.width(), CV_32F);
    rng->fill(noise, cv::RNG::NORMAL, 0.0, noise_sigma);
    const Eigen::Matrix3d R = world_T_cam.rotationMatrix();
    const Eigen::Vector3d o = world_T_cam.translation();
    const double half[3] = {kHalfX, kHalfY, kHalfZ};  // texture coordinates
    for (int v = 0; v < camera.height(); ++v) {
      float* row = value_image.ptr<float>(v);
      const float* n = noise.ptr<float>(v);
      for (int u = 0; u < camera.width(); ++u) {
        const Eigen::Vector3d d = R * Eigen::Vector3d((u - camera.cx()) / camera.fx(),
                                                      (v - camera.cy()) / camera.fy(), 1.0);
        int axis = 0;
        const Eigen::Vector3d p = o + exitDistance(o, d, &axis) * d;
        double value = 128.0;
        if (!blank) {
          const int face = 2 * axis + (d[axis] > 0 ? 1 : 0);
          // The two other coordinates, mapped onto the whole texture.
          const int a1 = axis == 0 ? 2 : 0, a2 = axis == 1 ? 2 : 1;
          const cv::Mat& tex = textures_[static_cast<size_t>(face)];
          const double s = (p[a1] + half[a1]) / (2 * half[a1]) * (tex.cols - 2);
          const double r = (p[a2] + half[a2]) / (2 * half[a2]) * (tex.rows - 2);
          value = brightness * sample(tex, s, r);
        }
        row[u] = static_cast<float>(value) + n[u];
      }
    }
    value_image.convertTo(*out, CV_8U);  // rounds and saturates
  }

  // From inside the box a ray o + t d leaves through the nearest face it points at: its t,
  // and the axis normal to that face.
  static double exitDistance(const Eigen::Vector3d& o, const Eigen::Vector3d& d, int* axis) {
    const double half[3] = {kHalfX, kHalfY, kHalfZ};
    double t_best = 1e30;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d[a]) < 1e-12) continue;
      const double t = ((d[a] > 0 ? half[a] : -half[a]) - o[a]) / d[a];
      if (t > 0 && t < t_best) {
        t_best = t;
        if (axis) *axis = a;
      }
    }
    return t_best;
  }

  static double sample(const cv::Mat& tex, double x, double y) {
    x = std::clamp(x, 0.0, tex.cols - 2.0);
    y = std::clamp(y, 0.0, tex.rows - 2.0);
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double ax = x - x0, ay = y - y0;
    const float* r0 = tex.ptr<float>(y0) + x0;
    const float* r1 = tex.ptr<float>(y0 + 1) + x0;
    return (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
  }

  std::array<cv::Mat, 6> textures_;
  bool ok_ = false;
};

// The camera of the synthetic rig: EuRoC-like rectified pinholes, 752x480, 0.11 m baseline.
inline core::StereoCamera syntheticCamera() {
  return *core::StereoCamera::create(436.0, 436.0, 376.0, 240.0, 0.11, 752, 480);
}

// A loop through the room: a circle of radius `radius_m` in the horizontal plane, looking
// along the direction of travel turned outward by 30°, with a gentle up-down motion and roll.
// `steps` poses over `turns` turns.
inline std::vector<core::SE3d> loopTrajectory(int steps, double radius_m = 1.5,
                                              double turns = 1.0) {
  std::vector<core::SE3d> poses;
  for (int k = 0; k < steps; ++k) {
    const double a = 2.0 * M_PI * turns * k / steps;
    const core::Vec3 position(radius_m * std::sin(a), 0.15 * std::sin(3 * a),
                              -radius_m * std::cos(a));
    // Heading: the tangent of the circle turned 30° outward; a yaw about y (down) turns the
    // camera's z axis to (sin yaw, 0, cos yaw).
    const core::Vec3 tangent(std::cos(a), 0.0, std::sin(a));
    const core::Vec3 outward(std::sin(a), 0.0, -std::cos(a));
    const core::Vec3 forward = std::cos(M_PI / 6) * tangent + std::sin(M_PI / 6) * outward;
    const double yaw = std::atan2(forward.x(), forward.z());
    const core::SO3d R =
        core::SO3d::exp(core::Vec3(0.0, yaw, 0.0)) *
        core::SO3d::exp(core::Vec3(0.05 * std::sin(2 * a), 0.0, 0.03 * std::cos(a)));
    poses.emplace_back(R, position);
  }
  return poses;
}

// `cam` as the calibration of already rectified images: both pinholes alike, the right one
// `baselineM()` to the right of the left.
inline core::StereoCalibration rectifiedCalibration(const core::StereoCamera& cam) {
  return core::rectifiedPair(
      core::pinholeCamera(cam.width(), cam.height(), cam.fx(), cam.fy(), cam.cx(), cam.cy()),
      cam.baselineM());
}

// `image` moved right by `px` whole pixels (a rig whose right cx is `px` off); the columns
// uncovered on the left keep their old pixels.
inline cv::Mat shiftedRight(const cv::Mat& image, int px) {
  if (px <= 0) return image;
  cv::Mat shifted = image.clone();
  image(cv::Rect(0, 0, image.cols - px, image.rows))
      .copyTo(shifted(cv::Rect(px, 0, image.cols - px, image.rows)));
  return shifted;
}

// The image with each row's content moved right by slope x (row - cy) pixels (bilinear): a
// right image whose disparities measure slope x (v - cy) short.
inline cv::Mat shearedRight(const cv::Mat& image, double slope, double cy) {
  const cv::Matx23d m(1.0, slope, -slope * cy, 0.0, 1.0, 0.0);
  cv::Mat out;
  cv::warpAffine(image, out, m, image.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace evermap::testing
