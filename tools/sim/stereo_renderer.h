#pragma once
// Renders rectified gray images of a RenderFloor (render_world.h).
//
// Every wall is vertical and spans floor to ceiling, and the robot's camera is nearly level
// (floor roughness of a few milliradians). So each image is rendered in two exact steps:
//  1. A *level* camera at the same centre, with the same heading and intrinsics but no roll or
//     pitch, and a margin of `kLevelMargin` pixels around the image. In a level camera an
//     image column is one horizontal direction: the nearest wall along it comes from a 1-D
//     depth buffer over columns, its texture column is fixed and its texture row is linear in
//     the image row; floor and ceiling points of one image row are at one depth (the classic
//     column renderer). Each pixel is exact at its centre; textures are sampled bilinearly
//     from the mip level of the pixel footprint (geometric mean of its two axes, so grazing
//     walls keep their detail).
//  2. The real camera differs from the level one by a rotation about the same centre, so its
//     image is the level image resampled through the homography K R K⁻¹ (exact for a pure
//     rotation; bilinear interpolation). The homography is evaluated exactly every 16 pixels
//     of a row and linearly in between (its denominator changes by ~1e-5 per pixel).
// The per-pixel loops (wall columns, floor and ceiling rows, the warp) are render_kernels.h:
// AVX2 when the CPU has it, else portable C++, with bit-identical images either way.
// Pixel (u, v) is the ray through the pixel centre, OpenCV's convention: u = fx x/z + cx.
//
// Output intensity: texture * light, then the session's camera response (gain, offset, gamma),
// then Gaussian sensor noise, clamped to 0..255.
//
// Depth (the RGB-D mode, depth_sensor.h adds the sensor's errors): the same ray cast gives the
// level camera's depth at each level pixel (a wall column's forward distance, a floor or
// ceiling row's, a passer-by's). A real pixel's depth along its camera's z axis is the level
// depth at its level position divided by the z of its rotated ray (the homography's
// denominator): z_cam = z_level / (level_R_cam K⁻¹ p)_z. The level depth is interpolated
// bilinearly in inverse depth (exact inside a plane, where 1/z is affine in the pixel) when
// the four level pixels around agree within 10 % (a floor far ahead changes by a few % a
// pixel), else taken from the nearest one, so depth edges stay sharp.

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "tools/sim/random.h"
#include "tools/sim/render_world.h"
#include "tools/sim/textures.h"

namespace evermap::sim {

// A rectified pinhole camera (no distortion).
struct PinholeCamera {
  int width = 640;
  int height = 480;
  double fx = 450.0, fy = 450.0;  // pixels
  double cx = 320.0, cy = 240.0;  // pixels
  Status validate() const;
};

// The camera response of one session: out = 255 * (gain * (in / 255)^gamma) + offset_gray.
struct Lighting {
  double gain = 1.0;
  double offset_gray = 0.0;
  double gamma = 1.0;
  Status validate() const;
};

// A passer-by: an upright textured rectangle standing on the floor, facing the camera.
struct Occluder {
  Vec2 centre = Vec2::Zero();  // of its bottom edge, world x y
  Vec2 normal = Vec2(1, 0);    // unit, horizontal, towards the camera
  double width_m = 0.8;
  double height_m = 1.8;
  int texture = 0;
  double texel_m = 0.01;
};

class ImageRenderer {
 public:
  // `noise_sigma_gray`: standard deviation of the sensor noise, gray levels (0: none).
  ImageRenderer(const TextureLibrary& textures, const PinholeCamera& camera,
                double noise_sigma_gray, uint64_t noise_seed);

  void setLighting(const Lighting& lighting);
  // Renders the view of a camera at world_T_cam (camera z forward, x right, y down) inside
  // `floor`, whose heights are shifted by z_shift (the closed elevator cab moves). `out`
  // becomes CV_8UC1 of the camera's size. `depth` (optional) becomes CV_32FC1 of the same
  // size: the exact depth of each pixel along the camera's z axis, metres (see above).
  void render(const RenderFloor& floor, double z_shift, const core::SE3d& world_T_cam,
              std::span<const Occluder> occluders, cv::Mat* out, cv::Mat* depth = nullptr);

  const PinholeCamera& camera() const { return camera_; }

 private:
  const TextureLibrary& textures_;
  PinholeCamera camera_;
  Random rng_;
  bool avx2_;  // the CPU has AVX2: use the AVX2 kernels (render_kernels.h)
  // The level image (a camera of the same centre looking horizontally along `heading`): the
  // walls' nearest per column, their spans, the floor and ceiling rows, the passers-by.
  struct LevelView;
  void renderLevel(const RenderFloor& floor, double z_shift, const core::Vec3& centre,
                   const core::Vec2& heading, std::span<const Occluder> occluders, bool with_depth);
  void nearestWalls(const RenderFloor& floor, const LevelView& view);
  void surfaceDepths(const LevelView& view);
  void drawWallColumn(const RenderFloor& floor, const LevelView& view, int u);
  void drawSurfaces(const RenderFloor& floor, const LevelView& view);
  void fillLevelDepth();
  void drawOccluders(const LevelView& view, std::span<const Occluder> occluders, bool with_depth);

  void warpDepth(const core::Mat3& M, cv::Mat* depth) const;

  std::vector<int16_t> noise_;     // Gaussian samples, read from a random offset per row
  std::vector<int32_t> response_;  // light (0..1023) -> gray, the session's camera response
  int level_w_ = 0, level_h_ = 0;
  std::vector<uint16_t> level_;     // the level image: light 0..1023, row-major
  std::vector<float> depth_;        // per level column: forward distance of the nearest wall
  std::vector<int> nearest_;        // per level column: that wall, -1 none
  std::vector<float> level_depth_;  // with depth: the level image's depth, row-major, metres
  // Per level row: the floor's or ceiling's forward distance and mip level part; per level
  // column: its mip level part, direction (x, y) and the wall's rows [top, bot).
  std::vector<float> row_t_, row_lod_, col_lod_, col_dx_, col_dy_;
  std::vector<int> col_top_, col_bot_;
};

}  // namespace evermap::sim
