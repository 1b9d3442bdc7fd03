#include "mapper-proc/constraint_set.h"

#include <algorithm>

#include <Eigen/Cholesky>

namespace evermap::mapper {

double ConstraintSet::mahalanobis2(const core::UncertainPose& m, const core::UncertainPose& z) {
  const core::Vec6 e = (m.mean.inverse() * z.mean).log();
  const core::Mat6 S = m.covariance + z.covariance;
  Eigen::LDLT<core::Mat6> ldlt(S);
  if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return e.dot(ldlt.solve(e));
}

core::UncertainPose ConstraintSet::fuse(const core::UncertainPose& m,
                                        const core::UncertainPose& z) {
  const core::Vec6 e = (m.mean.inverse() * z.mean).log();
  const core::Mat6 S = m.covariance + z.covariance;
  const core::Mat6 K = S.transpose().ldlt().solve(m.covariance.transpose()).transpose();
  core::UncertainPose out;
  out.mean = m.mean * core::SE3d::exp(K * e);
  const core::Mat6 fused = (core::Mat6::Identity() - K) * m.covariance;
  out.covariance = 0.5 * (fused + fused.transpose());
  return out;
}

int ConstraintSet::partners(int64_t node) const {
  return node >= 0 && static_cast<size_t>(node) < partners_.size()
             ? partners_[static_cast<size_t>(node)]
             : 0;
}

ConstraintSet::Outcome ConstraintSet::add(const Constraint& constraint, const Pair** pair,
                                          double* d2_out, core::UncertainPose* paired_out) {
  Constraint made = constraint;
  if (made.from > made.to) {
    made.from_T_to = core::invert(made.from_T_to);
    std::swap(made.from, made.to);
  }
  all_.push_back(made);
  const size_t k = all_.size() - 1;
  Constraint& c = all_[k];
  if (pair) *pair = nullptr;
  if (paired_out) *paired_out = c.from_T_to;
  const auto key = std::make_pair(c.from, c.to);
  auto it = pairs_.find(key);
  if (it == pairs_.end()) {
    c.accepted = true;
    Pair p;
    p.i = c.from;
    p.j = c.to;
    p.i_T_j = c.from_T_to;
    p.members.push_back(k);
    it = pairs_.emplace(key, p).first;
    for (const int64_t node : {c.from, c.to}) {
      if (node < 0) continue;
      if (static_cast<size_t>(node) >= partners_.size())
        partners_.resize(static_cast<size_t>(node) + 1, 0);
      ++partners_[static_cast<size_t>(node)];
    }
    if (pair) *pair = &it->second;
    if (d2_out) *d2_out = 0.0;
    return Outcome::kNewPair;
  }
  Pair& p = it->second;
  const double d2 = mahalanobis2(p.i_T_j, c.from_T_to);
  if (d2_out) *d2_out = d2;
  if (pair) *pair = &p;
  p.members.push_back(k);
  if (!(d2 <= gate_)) {
    c.accepted = false;
    ++p.rejected;
    ++rejected_;
    return Outcome::kRejected;
  }
  p.i_T_j = fuse(p.i_T_j, c.from_T_to);
  c.accepted = true;
  ++merged_;
  return Outcome::kMerged;
}

}  // namespace evermap::mapper
