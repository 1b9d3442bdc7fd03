#include "core/geometry/se2.h"

#include <cmath>
#include <numbers>

namespace evermap::core {

double wrapAngle(double a) {
  constexpr double kPi = std::numbers::pi;
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

Mat2 SE2d::rotationMatrix() const {
  const double c = std::cos(theta_);
  const double s = std::sin(theta_);
  Mat2 R;
  R << c, -s, s, c;
  return R;
}

SE2d SE2d::operator*(const SE2d& b) const {
  const Vec2 t = rotationMatrix() * b.translation() + translation();
  return SE2d(t.x(), t.y(), theta_ + b.theta_);
}

SE2d SE2d::inverse() const {
  const Vec2 t = -(rotationMatrix().transpose() * translation());
  return SE2d(t.x(), t.y(), -theta_);
}

namespace {

// V(w) = [[a, -b], [b, a]], the matrix that maps the translation part of a tangent vector to
// the translation of exp: a = sin(w)/w, b = (1 - cos(w))/w, by their series near w = 0.
void leftJacobianCoefficients(double w, double* a, double* b) {
  if (std::abs(w) < 1e-9) {
    *a = 1.0 - w * w / 6.0;
    *b = 0.5 * w;
  } else {
    *a = std::sin(w) / w;
    *b = (1.0 - std::cos(w)) / w;
  }
}

}  // namespace

SE2d SE2d::exp(const Eigen::Vector3d& xi) {
  const double w = xi.z();
  double a;
  double b;
  leftJacobianCoefficients(w, &a, &b);
  const double x = a * xi.x() - b * xi.y();
  const double y = b * xi.x() + a * xi.y();
  return SE2d(x, y, w);
}

Eigen::Vector3d SE2d::log() const {
  const double w = theta_;
  double a;
  double b;
  leftJacobianCoefficients(w, &a, &b);
  // Invert V = [[a, -b], [b, a]].
  const double det = a * a + b * b;
  const double vx = (a * x_ + b * y_) / det;
  const double vy = (-b * x_ + a * y_) / det;
  return Eigen::Vector3d(vx, vy, w);
}

SE2d compose(const SE2d& a, const SE2d& b, Eigen::Matrix3d* J_a, Eigen::Matrix3d* J_b) {
  const double c = std::cos(a.theta());
  const double s = std::sin(a.theta());
  if (J_a) {
    *J_a << 1.0, 0.0, -s * b.x() - c * b.y(), 0.0, 1.0, c * b.x() - s * b.y(), 0.0, 0.0, 1.0;
  }
  if (J_b) {
    *J_b << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  }
  return a * b;
}

SE2d inverse(const SE2d& a, Eigen::Matrix3d* J_a) {
  const double c = std::cos(a.theta());
  const double s = std::sin(a.theta());
  if (J_a) {
    *J_a << -c, -s, a.x() * s - a.y() * c, s, -c, a.x() * c + a.y() * s, 0.0, 0.0, -1.0;
  }
  return a.inverse();
}

SE2d between(const SE2d& a, const SE2d& b, Eigen::Matrix3d* J_a, Eigen::Matrix3d* J_b) {
  Eigen::Matrix3d Jinv;
  Eigen::Matrix3d J1;
  const SE2d ai = inverse(a, J_a ? &Jinv : nullptr);
  const SE2d ab = compose(ai, b, J_a ? &J1 : nullptr, J_b);
  if (J_a) *J_a = J1 * Jinv;
  return ab;
}

SE2d toPlanar(const SE3d& world_T_body) {
  const Vec3 x_axis = world_T_body.rotationMatrix().col(0);
  const Vec3& t = world_T_body.translation();
  return SE2d(t.x(), t.y(), std::atan2(x_axis.y(), x_axis.x()));
}

SE3d fromPlanar(const SE2d& pose, double z) {
  return SE3d(SO3d::fromRollPitchYaw(0.0, 0.0, pose.theta()), Vec3(pose.x(), pose.y(), z));
}

PlanarCell PlanarGrid::cellOf(const SE2d& pose, int floor) const {
  PlanarCell c;
  c.floor = floor;
  c.ix = static_cast<int>(std::floor(pose.x() / cell_size_m));
  c.iy = static_cast<int>(std::floor(pose.y() / cell_size_m));
  const double turn = (pose.theta() + std::numbers::pi) / (2.0 * std::numbers::pi);
  c.iheading = static_cast<int>(std::floor(turn * heading_bins)) % heading_bins;
  return c;
}

size_t PlanarCellHash::operator()(const PlanarCell& c) const {
  size_t h = std::hash<int>()(c.floor);
  for (int v : {c.ix, c.iy, c.iheading}) h = h * 1000003u ^ std::hash<int>()(v);
  return h;
}

}  // namespace evermap::core
