#include "tools/sim/landmark_graphs.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "tools/sim/random.h"

namespace evermap::sim {
namespace {

using core::SE2d;
using core::SE3d;
using core::Vec2;
using core::Vec3;

double sigmaOr(double sigma, double nominal) { return sigma > 0.0 ? sigma : nominal; }

// The nearest landmarks within range of a position, at most `max_count`, nearest first.
std::vector<int> visible(const Vec3& at, const std::vector<Vec3>& points, double range,
                         int max_count) {
  std::vector<std::pair<double, int>> near;
  for (int j = 0; j < static_cast<int>(points.size()); ++j) {
    const double d = (points[j] - at).norm();
    if (d <= range) near.emplace_back(d, j);
  }
  std::sort(near.begin(), near.end());
  std::vector<int> out;
  for (int k = 0; k < static_cast<int>(near.size()) && k < max_count; ++k)
    out.push_back(near[k].second);
  return out;
}

// Landmark ids in order of first sight, so that the written ids are 0, 1, ... as in iSAM.
struct IdMap {
  std::vector<int> file_id;  // by placed landmark, -1 until seen
  std::vector<Vec3> points;  // truth by file id
  int idOf(int placed, const std::vector<Vec3>& placed_points) {
    if (file_id[placed] < 0) {
      file_id[placed] = static_cast<int>(points.size());
      points.push_back(placed_points[placed]);
    }
    return file_id[placed];
  }
};

// The iSAM text of a graph being written: its stream, the square-root information of its
// measurements, and the landmark ids it has given out.
struct IsamText {
  IsamText(const LandmarkGraphOptions& o, size_t landmarks)
      : st(sigmaOr(o.odometry_sigma_m, o.nominal_sigma)),
        sr(sigmaOr(o.odometry_sigma_rad, o.nominal_sigma)),
        sp(sigmaOr(o.point_sigma_m, o.nominal_sigma)),
        ids{std::vector<int>(landmarks, -1), {}} {
    out.precision(17);
  }
  // The text, the observed landmarks and their count into `g`.
  void finish(LandmarkGraph* g) {
    g->isam_text = out.str();
    g->points = ids.points;
    g->observed_landmarks = static_cast<int>(ids.points.size());
  }

  const double st, sr, sp;  // odometry translation and rotation, points (sigmas)
  std::ostringstream out;
  IdMap ids;
};

// The torus of torusPointsLike: its surface point and outward normal at angles (u, v).
struct Torus {
  double R = 10.0, r = 3.0;
  Vec3 surface(double u, double v) const {
    return Vec3((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                r * std::sin(v));
  }
  Vec3 normal(double u, double v) const {
    return Vec3(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
  }
};

// The torus path's poses in the world, x along the path and z along the surface's normal:
// about 1 m between poses, twice round the major circle while winding around the minor one.
std::vector<SE3d> torusPath(const Torus& torus, int poses) {
  const double two_pi = 2.0 * std::numbers::pi;
  const double turns_u = 2.0;
  const double winds_v = std::max(1.0, std::round(poses / 60.0));
  auto at = [&](int i) {
    const double s = static_cast<double>(i) / poses;
    return std::pair<double, double>(two_pi * turns_u * s, two_pi * winds_v * s);
  };
  std::vector<SE3d> world;
  for (int i = 0; i < poses; ++i) {
    const auto [u, v] = at(i);
    const auto [u2, v2] = at(i + 1);
    const Vec3 p = torus.surface(u, v);
    const Vec3 x = (torus.surface(u2, v2) - p).normalized();
    const Vec3 n = torus.normal(u, v);
    const Vec3 z = (n - n.dot(x) * x).normalized();
    core::Mat3 Rm;
    Rm.col(0) = x;
    Rm.col(1) = z.cross(x);
    Rm.col(2) = z;
    world.emplace_back(core::SO3d::fromMatrix(Rm), p);
  }
  return world;
}

}  // namespace

LandmarkGraphOptions cityTreesOptions(int poses, uint64_t seed) {
  LandmarkGraphOptions o;
  o.poses = poses;
  o.landmarks = poses / 10;
  o.seed = seed;
  return o;
}

LandmarkGraphOptions torusPointsOptions(int poses, uint64_t seed) {
  LandmarkGraphOptions o;
  o.poses = poses;
  o.landmarks = poses / 5;
  o.odometry_sigma_m = 0.02;
  o.odometry_sigma_rad = 0.005;
  o.seed = seed;
  return o;
}

LandmarkGraph cityTreesLike(const LandmarkGraphOptions& o) {
  Random motion = Random::derive(o.seed, 1);
  Random place = Random::derive(o.seed, 2);
  Random noise = Random::derive(o.seed, 3);
  LandmarkGraph g;
  g.dimension = 2;
  // A square of side ~ sqrt(poses) so that the walk revisits places (like city10000).
  const int half = std::max(3, static_cast<int>(std::sqrt(static_cast<double>(o.poses)) / 2));
  std::vector<Vec3> placed;
  for (int j = 0; j < o.landmarks; ++j) {
    placed.emplace_back(place.uniform(-half - 1.0, half + 1.0),
                        place.uniform(-half - 1.0, half + 1.0), 0.0);
  }
  SE2d pose;
  g.poses2.push_back(pose);
  const double quarter = std::numbers::pi / 2.0;
  for (int i = 1; i < o.poses; ++i) {
    double turn = 0.0;
    if (motion.bernoulli(0.3)) turn = motion.bernoulli(0.5) ? quarter : -quarter;
    for (int tries = 0; tries < 4; ++tries) {
      const SE2d next = pose * SE2d(0.0, 0.0, turn) * SE2d(1.0, 0.0, 0.0);
      if (std::abs(next.x()) <= half + 1e-9 && std::abs(next.y()) <= half + 1e-9) break;
      turn += quarter;
    }
    pose = pose * SE2d(0.0, 0.0, turn) * SE2d(1.0, 0.0, 0.0);
    // Snap to the grid so that rounding does not drift over thousands of steps.
    pose = SE2d(std::round(pose.x()), std::round(pose.y()),
                std::round(pose.theta() / quarter) * quarter);
    g.poses2.push_back(pose);
  }
  IsamText text(o, placed.size());
  std::ostringstream& out = text.out;
  const double st = text.st, sr = text.sr, sp = text.sp;
  auto observe = [&](int i) {
    const SE2d& p = g.poses2[i];
    for (int j :
         visible(Vec3(p.x(), p.y(), 0.0), placed, o.sensor_range_m, o.max_observations_per_pose)) {
      const int id = text.ids.idOf(j, placed);
      const Vec2 z = p.rotationMatrix().transpose() * (placed[j].head<2>() - p.translation());
      out << "LANDMARK " << i << ' ' << id << ' ' << z.x() + noise.normal(0.0, o.point_sigma_m)
          << ' ' << z.y() + noise.normal(0.0, o.point_sigma_m) << ' ' << 1.0 / sp << " 0 "
          << 1.0 / sp << '\n';
      ++g.observations;
    }
  };
  observe(0);
  for (int i = 1; i < o.poses; ++i) {
    const SE2d z = g.poses2[i - 1].inverse() * g.poses2[i];
    out << "EDGE2 " << i - 1 << ' ' << i << ' ' << z.x() + noise.normal(0.0, o.odometry_sigma_m)
        << ' ' << z.y() + noise.normal(0.0, o.odometry_sigma_m) << ' '
        << z.theta() + noise.normal(0.0, o.odometry_sigma_rad) << ' ' << 1.0 / st << " 0 0 "
        << 1.0 / st << " 0 " << 1.0 / sr << '\n';
    observe(i);
  }
  text.finish(&g);
  return g;
}

LandmarkGraph torusPointsLike(const LandmarkGraphOptions& o) {
  Random place = Random::derive(o.seed, 2);
  Random noise = Random::derive(o.seed, 3);
  LandmarkGraph g;
  g.dimension = 3;
  const Torus torus;
  const std::vector<SE3d> world = torusPath(torus, o.poses);
  // Express everything relative to pose 0 (iSAM's anchor at the origin).
  const SE3d origin_inv = world[0].inverse();
  for (const SE3d& w : world) g.poses3.push_back(origin_inv * w);
  std::vector<Vec3> placed;
  for (int j = 0; j < o.landmarks; ++j) {
    const double u = place.uniform(0.0, 2.0 * std::numbers::pi);
    const double v = place.uniform(0.0, 2.0 * std::numbers::pi);
    placed.push_back(origin_inv *
                     (torus.surface(u, v) + place.uniform(0.5, 2.0) * torus.normal(u, v)));
  }
  IsamText text(o, placed.size());
  std::ostringstream& out = text.out;
  const double st = text.st, sr = text.sr, sp = text.sp;
  auto observe = [&](int i) {
    const SE3d& p = g.poses3[i];
    for (int j : visible(p.translation(), placed, o.sensor_range_m, o.max_observations_per_pose)) {
      const int id = text.ids.idOf(j, placed);
      const Vec3 z = p.inverse() * placed[j];
      out << "POINT3 " << i << ' ' << id;
      for (int k = 0; k < 3; ++k) out << ' ' << z[k] + noise.normal(0.0, o.point_sigma_m);
      out << ' ' << 1.0 / sp << " 0 0 " << 1.0 / sp << " 0 " << 1.0 / sp << '\n';
      ++g.observations;
    }
  };
  observe(0);
  for (int i = 1; i < o.poses; ++i) {
    Eigen::Matrix<double, 6, 1> xi;
    for (int k = 0; k < 3; ++k) xi[k] = noise.normal(0.0, o.odometry_sigma_m);
    for (int k = 3; k < 6; ++k) xi[k] = noise.normal(0.0, o.odometry_sigma_rad);
    const SE3d z = g.poses3[i - 1].inverse() * g.poses3[i] * SE3d::exp(xi);
    const Vec3 rpy = z.so3().rollPitchYaw();
    out << "EDGE3 " << i - 1 << ' ' << i;
    for (int k = 0; k < 3; ++k) out << ' ' << z.translation()[k];
    for (int k = 0; k < 3; ++k) out << ' ' << rpy[k];
    // Square-root information, 21 upper-triangular entries row by row.
    for (int row = 0; row < 6; ++row) {
      for (int col = row; col < 6; ++col) {
        out << ' ' << (row != col ? 0.0 : (row < 3 ? 1.0 / st : 1.0 / sr));
      }
    }
    out << '\n';
    observe(i);
  }
  text.finish(&g);
  return g;
}

}  // namespace evermap::sim
