#pragma once
// Robust kernels ρ(s) applied to a factor's squared whitened residual s = ‖W r‖².
//
// The cost of a factor is ρ(s) (no ½; ρ(s) = s without a kernel). The solver minimises it by
// iteratively reweighted least squares: at each linearisation the whitened residual and
// Jacobian are scaled by √ρ'(s) (the convention of GTSAM's noiseModel::Robust).
// Note: the original iSAM applies its pseudo-Huber function to each whitened component
// separately; we apply every kernel to the factor's whole squared error, so that a factor
// is an inlier or an outlier as a unit.
//
//  pseudo-Huber (b):  ρ = 2b²(√(1 + s/b²) − 1)            Hartley & Zisserman (2004) A6.8
//  Cauchy (b):        ρ = b² log(1 + s/b²)                 ibid.
//  DCS (Φ, default 20): IRLS weight m², m = min(1, 2Φ/(Φ + s)), and the matching cost
//                     ρ = s for s ≤ Φ, else 3Φ − 4Φ²/(Φ + s) (the integral of m², bounded by 3Φ)
//                     Agarwal et al., "Robust map optimization using dynamic covariance
//                     scaling", ICRA 2013: switchable constraints with the switch eliminated
//                     in closed form. (g2o reports m² s as the cost, which is not the
//                     integral of its weight; we keep cost and weight consistent.)
//  GNC-TLS (c̄², μ):   the graduated non-convexity surrogate of the truncated least squares
//                     cost min(s, c̄²) (Yang, Antonante, Tzoumas & Carlone, "Graduated
//                     Non-Convexity for Robust Spatial Perception", RA-L 2020, eq. (10)):
//                       ρ = s                                  for s ≤ c̄² μ/(μ+1)
//                       ρ = 2c̄ √(μ(μ+1)s) − μ(c̄² + s)          in between
//                       ρ = c̄²                                 for s ≥ c̄² (μ+1)/μ
//                     weight ρ' = c̄ √(μ(μ+1)/s) − μ in between (1 and 0 outside). In √s it
//                     is convex in the limit μ → 0 (the middle piece is ℓ1-like, curvature
//                     −2μ) and TLS as μ → ∞; solveGnc (core/solver/gnc.h) raises μ.

#include <string>

#include "core/common/expected.h"

namespace evermap::solver {

enum class KernelType { kNone, kPseudoHuber, kCauchy, kDcs, kGncTls };

struct RobustKernel {
  KernelType type = KernelType::kNone;
  // b for pseudo-Huber and Cauchy (in whitened units, i.e. standard deviations), Φ for DCS,
  // c̄² for GNC-TLS (in units of s; 0 = the 0.99 quantile of χ² with the factor's dimension,
  // filled in when the factor is built).
  double parameter = 1.0;
  // GNC-TLS only: the continuation parameter μ > 0.
  double gnc_mu = 1.0;

  bool active() const { return type != KernelType::kNone; }
  // ρ(s).
  double cost(double s) const;
  // ρ'(s), the IRLS weight.
  double weight(double s) const;
  std::string name() const;
};

// "none", "pseudo-huber", "cauchy", "dcs", "gnc", with an optional ":<parameter>" suffix.
Expected<RobustKernel> parseRobustKernel(const std::string& text);

// The p-quantile of the χ² distribution with k degrees of freedom (Wilson & Hilferty 1931
// approximation, within 1 % for k ≥ 3 at p = 0.99).
double chiSquareQuantile(int k, double p);

}  // namespace evermap::solver
