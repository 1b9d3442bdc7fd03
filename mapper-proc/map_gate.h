#pragma once
// The map gate (MapperOptions::map_gate): a registration tested against what the map already
// says, a closure's a_T_b against the map's estimate of it with its marginal covariance (the
// joint marginal of a and b through the relative-pose Jacobians). Catches false matches the
// per-pair test cannot see (a pair's first constraint).

#include <cstdint>
#include <optional>

#include "core/geometry/se3.h"
#include "mapper-proc/solver_schedule.h"

namespace evermap::mapper {

class MapGate {
 public:
  // gate: χ² bound (6 dof); 0 disables the gate (everything is consistent).
  explicit MapGate(double gate) : gate_(gate) {}

  bool active() const { return gate_ > 0; }
  // Whether a_T_b agrees with the map's estimate. information (when given): the closure's
  // mutual information with the map, ½ ln det(Σ_map + Σ_z) / det(Σ_z), nats
  // (MapperOptions::saturated_closure_information); infinity without a marginal. seconds: the
  // time the marginals took is added to it.
  bool consistent(const SolverSchedule& map, int64_t a, int64_t b, const core::UncertainPose& a_T_b,
                  double* information, double* seconds) const;
  // Whether two estimates of one pose agree (a registration to the active node against Δ).
  bool agree(const core::UncertainPose& m, const core::UncertainPose& z) const;
  // The map's estimate of a_T_b with its marginal covariance; empty when the solver gives no
  // marginal.
  static std::optional<core::UncertainPose> relative(const SolverSchedule& map, int64_t a,
                                                     int64_t b);

 private:
  double gate_;
};

}  // namespace evermap::mapper
