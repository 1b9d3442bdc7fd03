#pragma once
// A nonlinear least-squares problem over poses: variables (Values) and factors, with
// removal (the reduced pose graph drops and replaces constraints). Both solvers work on one.
//
// Costs (no ½ anywhere, as iSAM and SE-Sync report them):
//   weighted SSE = Σ_f ‖W_f r_f‖²       (iSAM's "weighted sum of squared errors"; = χ²)
//   robust cost  = Σ_f ρ_f(‖W_f r_f‖²)  (what the solver minimises; = SSE without kernels)

#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/solver/factor.h"
#include "core/solver/values.h"

namespace evermap::solver {

using FactorId = int;

struct Cost {
  double robust = 0.0;        // Σ ρ(s)
  double weighted_sse = 0.0;  // Σ s
  int64_t residual_dim = 0;   // Σ dim(f)
};

class PoseGraph {
 public:
  // Errors when the key exists.
  Status addVariable(Key key, const PoseValue& value);
  const Values& values() const { return values_; }
  Values& mutableValues() { return values_; }

  // Errors when a key is unknown or its variable kind does not match the factor.
  Expected<FactorId> addFactor(FactorPtr factor);
  // Errors when the id is unknown or already removed.
  Status removeFactor(FactorId id);

  int numFactorSlots() const { return static_cast<int>(factors_.size()); }
  int numActiveFactors() const { return num_active_; }
  bool isActive(FactorId id) const { return factors_[id] != nullptr; }
  const Factor& factor(FactorId id) const { return *factors_[id]; }
  const FactorPtr& factorPtr(FactorId id) const { return factors_[id]; }
  // Dense variable indices of a factor's keys.
  std::span<const int> variablesOf(FactorId id) const { return vars_[id]; }

  Cost cost() const { return cost(values_); }
  Cost cost(const Values& at) const;
  Cost cost(const Values& at, FactorId id) const;

 private:
  Values values_;
  std::vector<FactorPtr> factors_;
  std::vector<std::vector<int>> vars_;
  int num_active_ = 0;
};

// One factor linearised for the solver: A = √w W J (m × Σ dims of its variables, blocks in
// key order) and b = −√w W r, with w = ρ'(‖W r‖²) the IRLS weight.
struct LinearizedFactor {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  double weighted_sse = 0.0;
  double robust_cost = 0.0;
};

// Linearises factor `id` at `at`; reuses out's storage.
void linearize(const PoseGraph& graph, const Values& at, FactorId id, LinearizedFactor* out);

}  // namespace evermap::solver
