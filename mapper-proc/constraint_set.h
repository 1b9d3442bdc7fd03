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
// Every constraint is kept as it was made (all(), the map store's rows).

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "core/geometry/se3.h"
#include "core/map/map_snapshot.h"

namespace evermap::mapper {

using map::Constraint;  // core/map/map_snapshot.h: as the map store holds it
using map::ConstraintKind;

class ConstraintSet {
 public:
  enum class Outcome { kNewPair, kMerged, kRejected };
  struct Pair {
    int64_t i = 0;
    int64_t j = 0;
    core::UncertainPose i_T_j;    // merged
    std::vector<size_t> members;  // indices into all()
    int64_t rejected = 0;
  };

  // gate: the χ² bound on d² (6 degrees of freedom).
  explicit ConstraintSet(double gate) : gate_(gate) {}

  // Adds and classifies a constraint; `pair` (when given) receives the pair it belongs to,
  // and `paired` the constraint as its pair sees it: i_T_j.
  Outcome add(const Constraint& constraint, const Pair** pair = nullptr, double* d2 = nullptr,
              core::UncertainPose* paired = nullptr);

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
  double gate_;
  std::vector<Constraint> all_;
  std::map<std::pair<int64_t, int64_t>, Pair> pairs_;
  std::vector<int> partners_;  // by node id
  int64_t merged_ = 0;
  int64_t rejected_ = 0;
};

}  // namespace evermap::mapper
