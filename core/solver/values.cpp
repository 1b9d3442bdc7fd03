#include "core/solver/values.h"

#include <cstdio>
#include <cstdlib>

namespace evermap::solver {

namespace {
void requirePoses(const PoseValue& a, const PoseValue& b, const char* what) {
  if (a.kind != b.kind || a.isPoint()) {
    std::fprintf(stderr, "evermap: %s: needs two poses of one kind\n", what);
    std::abort();
  }
}
}  // namespace

PoseValue compose(const PoseValue& a, const PoseValue& b) {
  requirePoses(a, b, "compose");
  if (a.kind == PoseKind::kSE2) return PoseValue::planar(a.se2 * b.se2);
  return PoseValue::spatial(a.se3 * b.se3);
}

PoseValue inverse(const PoseValue& a) {
  requirePoses(a, a, "inverse");
  if (a.kind == PoseKind::kSE2) return PoseValue::planar(a.se2.inverse());
  return PoseValue::spatial(a.se3.inverse());
}

PoseValue retract(const PoseValue& x, const double* delta) {
  PoseValue out = x;
  if (x.kind == PoseKind::kPoint2) {
    out.point.x() += delta[0];
    out.point.y() += delta[1];
  } else if (x.kind == PoseKind::kPoint3) {
    out.point += Eigen::Map<const core::Vec3>(delta);
  } else if (x.kind == PoseKind::kSE2) {
    const core::Vec2 t =
        x.se2.translation() + x.se2.rotationMatrix() * core::Vec2(delta[0], delta[1]);
    out.se2 = core::SE2d(t.x(), t.y(), x.se2.theta() + delta[2]);
  } else {
    const Eigen::Map<const core::Vec3> v(delta);
    const Eigen::Map<const core::Vec3> w(delta + 3);
    out.se3 = core::SE3d(x.se3.so3() * core::SO3d::exp(w), x.se3.translation() + x.se3.so3() * v);
  }
  return out;
}

bool allFinite(const PoseValue& x) {
  switch (x.kind) {
    case PoseKind::kSE2:
      return x.se2.vector().allFinite();
    case PoseKind::kSE3:
      return x.se3.translation().allFinite() && x.se3.quaternion().coeffs().allFinite();
    default:
      return x.point.allFinite();
  }
}

int Values::add(Key key, const PoseValue& value) {
  if (index_.count(key)) {
    std::fprintf(stderr, "evermap: Values::add: key %lld added twice\n",
                 static_cast<long long>(key));
    std::abort();
  }
  const int i = size();
  index_.emplace(key, i);
  values_.push_back(value);
  keys_.push_back(key);
  offsets_.push_back(total_dim_);
  total_dim_ += value.dim();
  return i;
}

int Values::indexOf(Key key) const {
  const auto it = index_.find(key);
  return it == index_.end() ? -1 : it->second;
}

const PoseValue& Values::operator[](Key key) const {
  const int i = indexOf(key);
  if (i < 0) {
    std::fprintf(stderr, "evermap: Values: unknown key %lld\n", static_cast<long long>(key));
    std::abort();
  }
  return values_[i];
}

void Values::retractAll(const Eigen::VectorXd& delta) {
  for (int i = 0; i < size(); ++i) values_[i] = retract(values_[i], delta.data() + offsets_[i]);
}

}  // namespace evermap::solver
