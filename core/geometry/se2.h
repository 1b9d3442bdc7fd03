#pragma once
// SE(2) poses for planar work: the solver's 2-D graphs and the mapper's per-floor partition
// of (x, y, heading).
//
// `a_T_b` maps points in frame b to frame a. Tangent order (υx, υy, ω), translation first.
// compose/between Jacobians are those of Smith, Self & Cheeseman (1990) on the (x, y, θ)
// vector, which for SE(2) coincide with right-perturbation Jacobians only at small angles;
// the SSC form is what the planar solver and the tracker use.

#include <algorithm>

#include <Eigen/Core>

#include "core/geometry/se3.h"

namespace evermap::core {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;

// Wraps an angle to (-pi, pi].
double wrapAngle(double a);

class SE2d {
 public:
  SE2d() = default;
  SE2d(double x, double y, double theta) : x_(x), y_(y), theta_(wrapAngle(theta)) {}

  double x() const { return x_; }
  double y() const { return y_; }
  double theta() const { return theta_; }
  Vec2 translation() const { return Vec2(x_, y_); }
  Eigen::Vector3d vector() const { return Eigen::Vector3d(x_, y_, theta_); }
  Mat2 rotationMatrix() const;

  SE2d operator*(const SE2d& b) const;
  Vec2 operator*(const Vec2& p) const { return rotationMatrix() * p + translation(); }
  SE2d inverse() const;

  // Lie-group exp/log with (υx, υy, ω).
  static SE2d exp(const Eigen::Vector3d& xi);
  Eigen::Vector3d log() const;

 private:
  double x_ = 0.0;
  double y_ = 0.0;
  double theta_ = 0.0;
};

// SSC head-to-tail compounding on (x, y, θ) with Jacobians J⊕ = [J1 | J2] (SSC eq. 3-4).
SE2d compose(const SE2d& a, const SE2d& b, Eigen::Matrix3d* J_a = nullptr,
             Eigen::Matrix3d* J_b = nullptr);
// SSC inverse ⊖ with its Jacobian.
SE2d inverse(const SE2d& a, Eigen::Matrix3d* J_a = nullptr);
// a^-1 * b on (x, y, θ), with Jacobians.
SE2d between(const SE2d& a, const SE2d& b, Eigen::Matrix3d* J_a = nullptr,
             Eigen::Matrix3d* J_b = nullptr);

// The planar part of a 3-D pose: (x, y, yaw), yaw of the body x axis in the world x-y plane.
SE2d toPlanar(const SE3d& world_T_body);
// A 3-D pose from a planar one at height z (roll = pitch = 0).
SE3d fromPlanar(const SE2d& pose, double z = 0.0);

// A cell of the per-floor partition of (x, y, heading) (paper section IV-B).
struct PlanarCell {
  int floor = 0;
  int ix = 0;
  int iy = 0;
  int iheading = 0;
  friend bool operator==(const PlanarCell&, const PlanarCell&) = default;
};

struct PlanarGrid {
  double cell_size_m = 1.0;
  int heading_bins = 8;  // 45° sectors
  PlanarCell cellOf(const SE2d& pose, int floor) const;
  // Calls f(cell) for every cell within `rings` cells (in x and in y) and `sector_rings`
  // heading sectors of c, on c's floor, each once (the heading wraps; at most every sector).
  template <class F>
  void forEachNear(const PlanarCell& c, int rings, int sector_rings, F&& f) const {
    sector_rings = std::min(sector_rings, heading_bins / 2);
    for (int dx = -rings; dx <= rings; ++dx) {
      for (int dy = -rings; dy <= rings; ++dy) {
        for (int dh = -sector_rings; dh <= sector_rings; ++dh) {
          // With an even number of sectors the opposite one is reached both ways: once.
          if (heading_bins % 2 == 0 && sector_rings == heading_bins / 2 && dh == -sector_rings)
            continue;
          f(PlanarCell{c.floor, c.ix + dx, c.iy + dy,
                       ((c.iheading + dh) % heading_bins + heading_bins) % heading_bins});
        }
      }
    }
  }
};

struct PlanarCellHash {
  size_t operator()(const PlanarCell& c) const;
};

}  // namespace evermap::core
