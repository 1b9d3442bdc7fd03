#include "mapper-proc/constraint_set.h"

#include <algorithm>
#include <set>

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

Constraint ConstraintSet::paired(const Constraint& constraint) const {
  Constraint c = constraint;
  const auto from = aliases_.find(c.from);
  if (from != aliases_.end()) {
    // r_T_f ⊕ f_T_t: a fixed pose on the left leaves the right perturbation at t as it is.
    c.from_T_to.mean = from->second.into_T_node * c.from_T_to.mean;
    c.from = from->second.into;
  }
  const auto to = aliases_.find(c.to);
  if (to != aliases_.end()) {
    // f_T_t ⊕ ⊖r_T_t: f_T_t exp(ξ) r_T_t⁻¹ = f_T_r exp(Ad(r_T_t) ξ).
    const core::SE3d& r_T_t = to->second.into_T_node;
    const core::Mat6 ad = r_T_t.adjoint();
    c.from_T_to.mean = c.from_T_to.mean * r_T_t.inverse();
    c.from_T_to.covariance = ad * c.from_T_to.covariance * ad.transpose();
    c.to = to->second.into;
  }
  return c;
}

int64_t ConstraintSet::setAliases(std::map<int64_t, NodeAlias> aliases) {
  // The nodes whose pairs change: merged, unmerged or merged elsewhere, and the nodes they
  // were or are part of. Their pairs (and the constraints of a merge itself among them) are
  // taken apart and their constraints placed again in the order they were made; a pair's
  // outcome depends on its own constraints alone, so the rest stand as a full replay would
  // leave them, and the work follows those nodes' pairs, not the constraints ever made.
  std::set<int64_t> touched;
  const auto note = [&touched](const std::map<int64_t, NodeAlias>& a,
                               const std::map<int64_t, NodeAlias>& b) {
    for (const auto& [node, alias] : a) {
      const auto other = b.find(node);
      if (other == b.end() || other->second.into != alias.into ||
          other->second.into_T_node.matrix() != alias.into_T_node.matrix()) {
        touched.insert(node);
        touched.insert(alias.into);
      }
    }
  };
  note(aliases_, aliases);
  note(aliases, aliases_);
  aliases_ = std::move(aliases);
  std::vector<size_t> again;
  for (auto it = pairs_.begin(); it != pairs_.end();) {
    const Pair& p = it->second;
    if (!touched.count(p.i) && !touched.count(p.j)) {
      ++it;
      continue;
    }
    for (const size_t k : p.members) {
      again.push_back(k);
      if (all_[k].accepted && k != p.members.front()) --merged_;
    }
    rejected_ -= p.rejected;
    for (const int64_t node : {p.i, p.j})
      if (node >= 0) --partners_[static_cast<size_t>(node)];
    it = pairs_.erase(it);
  }
  for (auto it = internal_.begin(); it != internal_.end();) {
    const Constraint& c = all_[*it];
    if (!touched.count(c.from) && !touched.count(c.to)) {
      ++it;
      continue;
    }
    again.push_back(*it);
    if (!c.accepted) --rejected_;
    it = internal_.erase(it);
  }
  std::sort(again.begin(), again.end());
  int64_t newly_rejected = 0;
  for (const size_t k : again) {
    const bool was = all_[k].accepted;
    place(k, nullptr, nullptr, nullptr);
    if (was && !all_[k].accepted) ++newly_rejected;
  }
  return newly_rejected;
}

ConstraintSet::Outcome ConstraintSet::add(const Constraint& constraint, const Pair** pair,
                                          double* d2_out, core::UncertainPose* paired_out) {
  Constraint made = constraint;
  if (made.from > made.to) {
    made.from_T_to = core::invert(made.from_T_to);
    std::swap(made.from, made.to);
  }
  all_.push_back(made);
  return place(all_.size() - 1, pair, d2_out, paired_out);
}

ConstraintSet::Outcome ConstraintSet::place(size_t k, const Pair** pair, double* d2_out,
                                            core::UncertainPose* paired_out) {
  Constraint& made = all_[k];
  Constraint c = aliases_.empty() ? made : paired(made);
  if (pair) *pair = nullptr;
  if (c.from == c.to) {
    // Between a merged node and its node: the merge's own pose is what it measures.
    const double d2 =
        mahalanobis2(core::UncertainPose{core::SE3d(), core::Mat6::Zero()}, c.from_T_to);
    if (d2_out) *d2_out = d2;
    if (paired_out) *paired_out = c.from_T_to;
    made.accepted = d2 <= gate_;
    internal_.push_back(k);
    if (made.accepted) return Outcome::kInternal;
    ++rejected_;
    return Outcome::kRejected;
  }
  if (c.from > c.to) {
    c.from_T_to = core::invert(c.from_T_to);
    std::swap(c.from, c.to);
  }
  if (paired_out) *paired_out = c.from_T_to;
  const auto key = std::make_pair(c.from, c.to);
  auto it = pairs_.find(key);
  if (it == pairs_.end()) {
    made.accepted = true;
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
    made.accepted = false;
    ++p.rejected;
    ++rejected_;
    return Outcome::kRejected;
  }
  p.i_T_j = fuse(p.i_T_j, c.from_T_to);
  made.accepted = true;
  ++merged_;
  return Outcome::kMerged;
}

}  // namespace evermap::mapper
