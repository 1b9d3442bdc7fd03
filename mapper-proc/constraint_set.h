#pragma once
// Every constraint between pairs of nodes, kept (paper section III-B.3; DESIGN.md section 3):
// several measurements of one pair are tested against each other and merged into the one
// factor the solver sees only when they agree; one that disagrees is rejected and counted.
//
// A pair (i, j) is stored with i < j as i_T_j. A new measurement z (covariance Σz) is tested
// against the pair's merged estimate m (Σm) by the Mahalanobis distance of
//   e = log(m⁻¹ z),  d² = eᵀ (Σm + Σz)⁻¹ e,
// both covariances in the tangent space at j (right perturbations). d² ≤ gate: merged by the
// information-weighted update on the manifold, K = Σm (Σm + Σz)⁻¹, m ← m exp(K e),
// Σm ← (I − K) Σm (a Kalman update with the measurement of the state itself).
//
// Merged nodes (MapperOptions::merge_radius_m): a node n merged into r is part of r, at the
// fixed pose r_T_n. Every constraint is kept as it was made (all(), the map store's rows),
// and is paired through the aliases: a constraint of n is one of r, re-expressed as
// r_T_n ⊕ n_T_c (its covariance moved to the tangent space at the new end by Ad(r_T_n) when
// n is that end). One between n and r is tested against r_T_n itself and makes no pair.
// Setting the aliases places the constraints of the pairs it changes again, in the order they
// were made, so that undoing a merge gives back the pairs as if it had never been made.

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "core/geometry/se3.h"
#include "core/map/map_snapshot.h"

namespace evermap::mapper {

using map::Constraint;  // core/map/map_snapshot.h: as the map store holds it
using map::ConstraintKind;

// A node merged into another: the node it is part of and its pose in that node's frame.
struct NodeAlias {
  int64_t into = -1;
  core::SE3d into_T_node;
};

class ConstraintSet {
 public:
  // kInternal: a constraint between a merged node and the node it is part of, agreeing with
  // the merge (no pair, no factor); one that disagrees is kRejected.
  enum class Outcome { kNewPair, kMerged, kRejected, kInternal };
  struct Pair {
    int64_t i = 0;
    int64_t j = 0;
    core::UncertainPose i_T_j;    // merged
    std::vector<size_t> members;  // indices into all()
    int64_t rejected = 0;
  };

  // gate: the χ² bound on d² (6 degrees of freedom).
  explicit ConstraintSet(double gate) : gate_(gate) {}

  // Adds and classifies a constraint; `pair` (when given) receives the pair it belongs to
  // (none for kInternal), and `paired` the constraint as its pair sees it: i_T_j through the
  // aliases.
  Outcome add(const Constraint& constraint, const Pair** pair = nullptr, double* d2 = nullptr,
              core::UncertainPose* paired = nullptr);

  // The merged nodes (node -> alias; an alias names a node that is not merged itself), and
  // the constraints placed again as if they had been added under them (those of the pairs of
  // the nodes whose merge changed). Returns how many constraints it accepted before and
  // rejects now.
  int64_t setAliases(std::map<int64_t, NodeAlias> aliases);
  const std::map<int64_t, NodeAlias>& aliases() const { return aliases_; }
  // The constraint c as paired under the aliases (its ends may be equal: kInternal).
  Constraint paired(const Constraint& c) const;

  const std::vector<Constraint>& all() const { return all_; }
  const std::map<std::pair<int64_t, int64_t>, Pair>& pairs() const { return pairs_; }
  // How many pairs `node` belongs to (its partners, odometry and loop alike): what
  // MapperOptions::closure_partners bounds. Follows from the constraints added, so a map
  // replayed from its store (Mapper::restore) counts the same.
  int partners(int64_t node) const;
  int64_t merged() const { return merged_; }
  int64_t rejected() const { return rejected_; }

  // Mahalanobis d² of z against m as above.
  static double mahalanobis2(const core::UncertainPose& m, const core::UncertainPose& z);
  // The information-weighted update of m by z, two independent estimates of one pose, as
  // above (also the tracker's fusion of Δ with a registration to the active node).
  static core::UncertainPose fuse(const core::UncertainPose& m, const core::UncertainPose& z);

 private:
  // Pairs all_[k] (kept as made) through the aliases.
  Outcome place(size_t k, const Pair** pair, double* d2, core::UncertainPose* paired);

  double gate_;
  std::map<int64_t, NodeAlias> aliases_;
  std::vector<size_t> internal_;  // constraints of a merge itself (kInternal or rejected as one)
  std::vector<Constraint> all_;
  std::map<std::pair<int64_t, int64_t>, Pair> pairs_;
  std::vector<int> partners_;  // by node id
  int64_t merged_ = 0;
  int64_t rejected_ = 0;
};

}  // namespace evermap::mapper
