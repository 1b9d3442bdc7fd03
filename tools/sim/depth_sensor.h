#pragma once
// A Kinect-like depth camera over the renderer's exact depth (ImageRenderer::render's `depth`
// output): what the image-level simulator's RGB-D mode publishes as the depth image of
// rgbd_image_t (docs/rgbd.md, docs/simulators.md "RGB-D mode").
//
// From an exact depth image (metres along the camera's z axis), per pixel, in this order:
//  1. holes at depth edges: a pixel whose 4-neighbour's depth differs by more than
//     `edge_jump_fraction` of the nearer one is an edge; edges are widened by `edge_hole_px`
//     (a square of side 2 edge_hole_px + 1);
//  2. the projector's shadow: the Kinect's projector sits `shadow_baseline_m` to the right of
//     its IR camera (+x), so the far surface just left of a near object's left edge is lit by
//     no pattern; those f b (1/z_near - 1/z_far) pixels have no depth (the triangulation of
//     a structured-light sensor, seen in every Kinect v1 image as a band left of objects);
//  3. a random dropout of `dropout_fraction` of the pixels;
//  4. noise: z + N(0, σ_z²), σ_z = noise_coefficient z² (1.425e-3 /m: Khoshelham & Elberink,
//     Sensors 2012, the model of core/camera/rgbd_camera.h);
//  5. out of range: a measured depth outside [min_range_m, max_range_m] has no depth;
//  6. quantisation to `unit_m` (the depth image's units; TUM and OpenNI: 1/5000 m).
// "No depth" is 0 in the output, as the Kinect's. Noise is independent per pixel (the real
// sensor's is correlated over its ~9x9 correlation window; a limit stated in the docs).
// Deterministic: the draws come from `seed` through Random, so a frame's depth depends on the
// seed and the frames measured before it.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/expected.h"
#include "tools/sim/random.h"

namespace evermap::sim {

struct DepthSensorOptions {
  double min_range_m = 0.5;             // nearer: no depth (Kinect v1: ~0.5 m)
  double max_range_m = 4.5;             // farther: no depth (Kinect v1: usable to 4-5 m)
  double noise_coefficient = 1.425e-3;  // σ_z = noise_coefficient z², 1/m (0: exact depth)
  double unit_m = 0.0002;               // metres per depth unit (max_range_m / unit_m < 65535)
  double edge_jump_fraction = 0.1;      // neighbours differing by more than this: a depth edge
  int edge_hole_px = 1;              // holes this far from a depth edge, pixels (0: the edge only)
  double shadow_baseline_m = 0.075;  // projector to IR camera, m (0: no shadows)
  double dropout_fraction = 0.002;   // pixels dropped at random

  Status validate() const;  // messages start with the field's name
};

class DepthSensor {
 public:
  // `fx`: focal length of the depth image, pixels (for the shadow's width).
  DepthSensor(const DepthSensorOptions& options, double fx, uint64_t seed);

  // `truth`: CV_32FC1, metres along the camera's z axis (not finite or <= 0: nothing there).
  // `out` becomes CV_16UC1 of the same size, in units of options().unit_m, 0 = no depth.
  void measure(const cv::Mat& truth, cv::Mat* out);

  // σ_z of a depth, metres.
  double sigma(double z_m) const { return options_.noise_coefficient * z_m * z_m; }
  const DepthSensorOptions& options() const { return options_; }

 private:
  DepthSensorOptions options_;
  double fx_;
  Random rng_;
  std::vector<float> normal_;      // standard normal samples, read from a random offset per row
  std::vector<uint32_t> uniform_;  // uniform 32-bit samples, the same way
  cv::Mat holes_, widened_;        // CV_8UC1 scratch
};

}  // namespace evermap::sim
