#pragma once
// The variables of a pose graph: SE(2) and SE(3) poses, and 2-D / 3-D point landmarks,
// keyed by an integer id.
//
// Retraction (the ⊞ the solver applies to a tangent step δ), right perturbations as in
// core/geometry:
//   SE(3): T ⊞ (υ, ω) = (R exp(ω), t + R υ)       — to first order T exp(ξ), so a covariance
//          of a pose lives in the pose's own frame, (υ, ω) order as the rest of the project.
//   SE(2): T ⊞ (υx, υy, ω) = (t + R(θ) υ, θ + ω)   — the planar analogue.
// The first-order behaviour equals T exp(ξ); only large steps differ, never the optimum.
//   points: l ⊞ δ = l + δ (world frame), 2 or 3 entries.

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::solver {

using Key = int64_t;

// The kind of a variable: a pose, or a point landmark (the name stayed when landmarks came).
enum class PoseKind : uint8_t { kSE2, kSE3, kPoint2, kPoint3 };

inline int tangentDim(PoseKind kind) {
  switch (kind) {
    case PoseKind::kSE2:
      return 3;
    case PoseKind::kSE3:
      return 6;
    case PoseKind::kPoint2:
      return 2;
    case PoseKind::kPoint3:
      return 3;
  }
  return 0;
}
inline bool isPointKind(PoseKind kind) {
  return kind == PoseKind::kPoint2 || kind == PoseKind::kPoint3;
}

// One variable. Only the member matching `kind` is meaningful (`point` for both point kinds;
// its z is 0 for a 2-D point).
struct PoseValue {
  PoseKind kind = PoseKind::kSE3;
  core::SE2d se2;
  core::SE3d se3;
  core::Vec3 point = core::Vec3::Zero();

  static PoseValue planar(const core::SE2d& p) {
    PoseValue v;
    v.kind = PoseKind::kSE2;
    v.se2 = p;
    return v;
  }
  static PoseValue spatial(const core::SE3d& p) {
    PoseValue v;
    v.kind = PoseKind::kSE3;
    v.se3 = p;
    return v;
  }
  static PoseValue point2(const core::Vec2& p_world) {
    PoseValue v;
    v.kind = PoseKind::kPoint2;
    v.point = core::Vec3(p_world.x(), p_world.y(), 0.0);
    return v;
  }
  static PoseValue point3(const core::Vec3& p_world) {
    PoseValue v;
    v.kind = PoseKind::kPoint3;
    v.point = p_world;
    return v;
  }
  int dim() const { return tangentDim(kind); }
  bool isPoint() const { return isPointKind(kind); }
};

// x ⊞ δ with δ of x.dim() entries (see the file comment).
PoseValue retract(const PoseValue& x, const double* delta);
// Every number of the value is finite (a diverged estimate is not).
bool allFinite(const PoseValue& x);
// a · b and a⁻¹, of b's kind as a's (contract: a and b are poses of one kind).
PoseValue compose(const PoseValue& a, const PoseValue& b);
PoseValue inverse(const PoseValue& a);

// A dense set of variables: index i in [0, size()) for each key, in insertion order.
class Values {
 public:
  // Adds a variable; contract: the key is new.
  int add(Key key, const PoseValue& value);
  bool contains(Key key) const { return index_.count(key) != 0; }
  // Dense index of a key, or -1.
  int indexOf(Key key) const;

  int size() const { return static_cast<int>(values_.size()); }
  const PoseValue& at(int index) const { return values_[index]; }
  const std::vector<PoseValue>& all() const { return values_; }
  PoseValue& at(int index) { return values_[index]; }
  const PoseValue& operator[](Key key) const;
  Key keyAt(int index) const { return keys_[index]; }
  const std::vector<Key>& keys() const { return keys_; }

  // Tangent offsets: variable i occupies [offset(i), offset(i) + dim(i)) of a stacked step.
  int offset(int index) const { return offsets_[index]; }
  int totalDim() const { return total_dim_; }

  // x ⊞ δ for every variable, δ stacked by offset().
  void retractAll(const Eigen::VectorXd& delta);

 private:
  std::vector<PoseValue> values_;
  std::vector<Key> keys_;
  std::vector<int> offsets_;
  std::unordered_map<Key, int> index_;
  int total_dim_ = 0;
};

}  // namespace evermap::solver
