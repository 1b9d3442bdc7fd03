#include "core/registration/clique_inliers.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "core/common/option_fields.h"

namespace evermap::core {

void CliqueOptions::declareOptions(OptionList& o) {
  o.add("threshold_m", &threshold_m, "m",
        "change of a pairwise distance always counted as consistent (FOVIS: 0.1 m)")
      .positive();
  o.add("sigmas", &sigmas, "", "standard deviations of the depth noise added to it").nonNegative();
}

namespace {

// popcount of a AND b over `words` 64-bit words. The clique search is mostly this; compiled
// twice (with the POPCNT instruction, and portable) and chosen at load time.
__attribute__((target_clones("popcnt", "default"))) int popcountAnd(const uint64_t* a,
                                                                    const uint64_t* b, int words) {
  int d = 0;
  for (int w = 0; w < words; ++w) d += __builtin_popcountll(a[w] & b[w]);
  return d;
}

// Row by row, the pairs (i, j > i) whose distance changes less than their threshold: the n²/2
// distance computations, compiled for AVX2 and for the baseline. w[k] = sigmas * s_k / z_k of
// each point (0: the fixed threshold).
__attribute__((target_clones("avx2", "default"))) void fillAdjacency(
    int n, int words, const float* __restrict ax, const float* __restrict ay,
    const float* __restrict az, const float* __restrict bx, const float* __restrict by,
    const float* __restrict bz, const float* __restrict wa, const float* __restrict wb, float t0,
    float* __restrict change, float* __restrict threshold, uint64_t* __restrict adj) {
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const float dax = ax[i] - ax[j], day = ay[i] - ay[j], daz = az[i] - az[j];
      const float dbx = bx[i] - bx[j], dby = by[i] - by[j], dbz = bz[i] - bz[j];
      const float la2 = dax * dax + day * day + daz * daz;
      const float lb2 = dbx * dbx + dby * dby + dbz * dbz;
      const float la = std::sqrt(la2), lb = std::sqrt(lb2);
      change[j] = std::abs(la - lb);
      // (e·p s / z)² of the four points, e = d / L: the projections of the pair's
      // difference on each ray, over L².
      const float ai = (dax * ax[i] + day * ay[i] + daz * az[i]) * wa[i];
      const float aj = (dax * ax[j] + day * ay[j] + daz * az[j]) * wa[j];
      const float bi = (dbx * bx[i] + dby * by[i] + dbz * bz[i]) * wb[i];
      const float bj = (dbx * bx[j] + dby * by[j] + dbz * bz[j]) * wb[j];
      const float var =
          (ai * ai + aj * aj) / std::max(la2, 1e-12f) + (bi * bi + bj * bj) / std::max(lb2, 1e-12f);
      threshold[j] = t0 + std::sqrt(var);
    }
    uint64_t* ri = adj + static_cast<size_t>(i) * words;
    for (int j = i + 1; j < n; ++j) {
      if (change[j] < threshold[j]) {
        ri[j >> 6] |= uint64_t{1} << (j & 63);
        adj[static_cast<size_t>(j) * words + (i >> 6)] |= uint64_t{1} << (i & 63);
      }
    }
  }
}

}  // namespace

std::vector<int> maxConsistentClique(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<double>& depth_sigma_a_m,
                                     const std::vector<double>& depth_sigma_b_m,
                                     const CliqueOptions& options) {
  if (points_a.size() != points_b.size() || depth_sigma_a_m.size() != depth_sigma_b_m.size() ||
      (!depth_sigma_a_m.empty() && depth_sigma_a_m.size() != points_a.size())) {
    std::fprintf(stderr,
                 "evermap: maxConsistentClique: %zu points against %zu (%zu and %zu sigmas)\n",
                 points_a.size(), points_b.size(), depth_sigma_a_m.size(), depth_sigma_b_m.size());
    std::abort();
  }
  const int n = static_cast<int>(points_a.size());
  if (n == 0) return {};
  const int words = (n + 63) / 64;
  // Row i of the adjacency matrix as a bit set.
  std::vector<uint64_t> adj(static_cast<size_t>(n) * words, 0);
  auto row = [&](int i) { return adj.data() + static_cast<size_t>(i) * words; };
  // Coordinates as float arrays, so the distance loop below vectorises (a few hundred
  // matches: n²/2 pairs is the bulk of the work).
  std::vector<float> c(static_cast<size_t>(8) * n);
  float* ax = c.data();
  float* ay = ax + n;
  float* az = ay + n;
  float* bx = az + n;
  float* by = bx + n;
  float* bz = by + n;
  float* wa = bz + n;  // sigmas * s / z
  float* wb = wa + n;
  const bool noisy = !depth_sigma_a_m.empty();
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<size_t>(i);
    const Eigen::Vector3d& a = points_a[k];
    const Eigen::Vector3d& b = points_b[k];
    ax[i] = static_cast<float>(a.x());
    ay[i] = static_cast<float>(a.y());
    az[i] = static_cast<float>(a.z());
    bx[i] = static_cast<float>(b.x());
    by[i] = static_cast<float>(b.y());
    bz[i] = static_cast<float>(b.z());
    auto weight = [&](double sigma, double z) {
      return noisy && z > 0.0 ? static_cast<float>(options.sigmas * sigma / z) : 0.0f;
    };
    wa[i] = weight(noisy ? depth_sigma_a_m[k] : 0.0, a.z());
    wb[i] = weight(noisy ? depth_sigma_b_m[k] : 0.0, b.z());
  }
  std::vector<float> change(static_cast<size_t>(n)), threshold(static_cast<size_t>(n));
  fillAdjacency(n, words, ax, ay, az, bx, by, bz, wa, wb, static_cast<float>(options.threshold_m),
                change.data(), threshold.data(), adj.data());
  // Seed: the vertex of highest degree.
  int seed = 0, seed_degree = -1;
  for (int i = 0; i < n; ++i) {
    const int d = popcountAnd(row(i), row(i), words);
    if (d > seed_degree) {
      seed = i;
      seed_degree = d;
    }
  }
  std::vector<int> clique = {seed};
  std::vector<uint64_t> candidates(row(seed), row(seed) + words);
  for (;;) {
    int best = -1, best_degree = -1;
    for (int w = 0; w < words; ++w) {
      for (uint64_t bits = candidates[static_cast<size_t>(w)]; bits; bits &= bits - 1) {
        const int i = w * 64 + std::countr_zero(bits);
        const int d = popcountAnd(row(i), candidates.data(), words);
        if (d > best_degree) {
          best = i;
          best_degree = d;
        }
      }
    }
    if (best < 0) break;
    clique.push_back(best);
    const uint64_t* r = row(best);
    for (int w = 0; w < words; ++w) candidates[static_cast<size_t>(w)] &= r[w];
  }
  std::sort(clique.begin(), clique.end());
  return clique;
}

}  // namespace evermap::core
