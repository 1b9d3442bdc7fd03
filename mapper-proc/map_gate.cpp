#include "mapper-proc/map_gate.h"

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>

#include "core/common/clocks.h"
#include "core/solver/marginals.h"
#include "mapper-proc/constraint_set.h"

namespace evermap::mapper {

std::optional<core::UncertainPose> MapGate::relative(const SolverSchedule& map, int64_t a,
                                                     int64_t b) {
  // From the solver's current factor by path solves (no copy of R): the work follows the
  // two nodes' elimination-tree paths, not the size of the map.
  const std::vector<solver::Key> keys{a, b};
  const auto joint = solver::Marginals::jointOf(map.solver(), keys);
  if (!joint) return std::nullopt;
  core::Mat6 Ja, Jb;
  core::UncertainPose predicted;
  predicted.mean = core::between(map.pose(a), map.pose(b), &Ja, &Jb);
  Eigen::Matrix<double, 6, 12> J;
  J << Ja, Jb;
  predicted.covariance = J * (*joint) * J.transpose();
  return predicted;
}

bool MapGate::agree(const core::UncertainPose& m, const core::UncertainPose& z) const {
  return !(gate_ > 0) || ConstraintSet::mahalanobis2(m, z) <= gate_;
}

bool MapGate::consistent(const SolverSchedule& map, int64_t a, int64_t b,
                         const core::UncertainPose& a_T_b, double* information,
                         double* seconds) const {
  if (information) *information = std::numeric_limits<double>::infinity();
  if (!(gate_ > 0)) return true;
  // The map's own estimate of a_T_b with its marginal covariance, against the measured chain.
  const auto t0 = SteadyClock::now();
  const std::optional<core::UncertainPose> predicted = relative(map, a, b);
  *seconds += secondsSince(t0);
  if (!predicted) return true;  // no marginal: nothing to test against
  if (information) {
    // ½ ln det(Σ_map + Σ_z) / det(Σ_z) from Cholesky factors (both positive definite).
    const Eigen::LLT<core::Mat6> sum(predicted->covariance + a_T_b.covariance);
    const Eigen::LLT<core::Mat6> z(a_T_b.covariance);
    if (sum.info() == Eigen::Success && z.info() == Eigen::Success) {
      double half_log_ratio = 0.0;
      for (int k = 0; k < 6; ++k)
        half_log_ratio += std::log(sum.matrixLLT()(k, k)) - std::log(z.matrixLLT()(k, k));
      *information = half_log_ratio;
    }
  }
  return ConstraintSet::mahalanobis2(*predicted, a_T_b) <= gate_;
}

}  // namespace evermap::mapper
