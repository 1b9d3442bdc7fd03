#include "core/solver/factor.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Cholesky>

namespace evermap::solver {

Factor::Factor(std::vector<Key> keys, Eigen::MatrixXd sqrt_information)
    : keys_(std::move(keys)), sqrt_information_(std::move(sqrt_information)) {
  const auto& W = sqrt_information_;
  bool ok = W.rows() == W.cols() && W.rows() > 0 && W.allFinite();
  for (int r = 0; ok && r < W.rows(); ++r) {
    for (int c = 0; c < r; ++c) ok = ok && W(r, c) == 0.0;
  }
  if (!ok) {
    std::fprintf(stderr,
                 "evermap: Factor: sqrt information must be square, finite, upper "
                 "triangular\n");
    std::abort();
  }
}

Expected<Eigen::MatrixXd> sqrtInformationFromInformation(const Eigen::MatrixXd& information,
                                                         const std::string& what) {
  if (!information.allFinite()) return makeError(what, ": information matrix is not finite");
  const double scale = information.cwiseAbs().maxCoeff();
  if ((information - information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + scale)) {
    return makeError(what, ": information matrix is not symmetric");
  }
  Eigen::LLT<Eigen::MatrixXd> llt(information);
  if (llt.info() != Eigen::Success) {
    return makeError(what, ": information matrix is not positive definite");
  }
  Eigen::MatrixXd W = llt.matrixU();
  for (int i = 0; i < W.rows(); ++i) {
    if (!(W(i, i) > 1e-12 * std::sqrt(1.0 + scale))) {
      return makeError(what, ": information matrix is not positive definite");
    }
  }
  return W;
}

Expected<Eigen::MatrixXd> checkSqrtInformation(const Eigen::MatrixXd& W, const std::string& what) {
  if (!W.allFinite()) return makeError(what, ": square-root information is not finite");
  for (int r = 0; r < W.rows(); ++r) {
    for (int c = 0; c < r; ++c) {
      if (W(r, c) != 0.0)
        return makeError(what, ": square-root information is not upper triangular");
    }
    if (W(r, r) == 0.0) {
      return makeError(what, ": square-root information is singular (zero on the diagonal)");
    }
  }
  return W;
}

std::vector<Eigen::MatrixXd> numericalJacobians(const Factor& factor,
                                                std::span<const PoseValue* const> x, double step) {
  const int m = factor.dim();
  std::vector<Eigen::MatrixXd> out;
  std::vector<PoseValue> perturbed(x.size());
  std::vector<const PoseValue*> ptrs(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    perturbed[i] = *x[i];
    ptrs[i] = &perturbed[i];
  }
  Eigen::VectorXd rp(m);
  Eigen::VectorXd rm(m);
  for (size_t i = 0; i < x.size(); ++i) {
    const int n = x[i]->dim();
    Eigen::MatrixXd J(m, n);
    for (int k = 0; k < n; ++k) {
      Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
      d[k] = step;
      perturbed[i] = retract(*x[i], d.data());
      factor.evaluate(ptrs, rp.data(), nullptr);
      d[k] = -step;
      perturbed[i] = retract(*x[i], d.data());
      factor.evaluate(ptrs, rm.data(), nullptr);
      J.col(k) = (rp - rm) / (2.0 * step);
    }
    perturbed[i] = *x[i];
    out.push_back(J);
  }
  return out;
}

}  // namespace evermap::solver
