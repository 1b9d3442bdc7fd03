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

// popcount of a AND b over `words` 64-bit words (the degrees the clique search starts from);
// compiled twice (with the POPCNT instruction, and portable) and chosen at load time.
__attribute__((target_clones("popcnt", "default"))) int popcountAnd(const uint64_t* a,
                                                                    const uint64_t* b, int words) {
  int d = 0;
  for (int w = 0; w < words; ++w) d += __builtin_popcountll(a[w] & b[w]);
  return d;
}

// Calls f(i) for every bit i set in `bits`, in increasing order.
template <typename F>
void forEachBit(const uint64_t* bits, int words, F f) {
  for (int w = 0; w < words; ++w) {
    for (uint64_t b = bits[w]; b; b &= b - 1) f(w * 64 + std::countr_zero(b));
  }
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

// Howard's greedy maximum clique over the adjacency bit sets (row i at adj + i * words): from
// the vertex of highest degree, the candidate with the most neighbours among the candidates,
// until none is left.
std::vector<int> greedyClique(int n, int words, const std::vector<uint64_t>& adj) {
  auto row = [&](int i) { return adj.data() + static_cast<size_t>(i) * words; };
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
  // degree[i]: neighbours of candidate i among the candidates. A step keeps the candidates
  // adjacent to the vertex taken; each one it drops lowers its neighbours' degree by one
  // (the adjacency is symmetric), which costs far less than counting every degree again.
  std::vector<int> degree(static_cast<size_t>(n), 0);
  forEachBit(candidates.data(), words, [&](int i) {
    degree[static_cast<size_t>(i)] = popcountAnd(row(i), candidates.data(), words);
  });
  std::vector<uint64_t> dropped(static_cast<size_t>(words));
  for (;;) {
    int best = -1, best_degree = -1;  // the first of the highest degree, in index order
    forEachBit(candidates.data(), words, [&](int i) {
      if (degree[static_cast<size_t>(i)] > best_degree) {
        best = i;
        best_degree = degree[static_cast<size_t>(i)];
      }
    });
    if (best < 0) break;
    clique.push_back(best);
    const uint64_t* r = row(best);
    for (int w = 0; w < words; ++w) {
      const auto k = static_cast<size_t>(w);
      dropped[k] = candidates[k] & ~r[w];
      candidates[k] &= r[w];
    }
    forEachBit(dropped.data(), words, [&](int d) {
      const uint64_t* rd = row(d);
      for (int w = 0; w < words; ++w) {
        for (uint64_t bits = candidates[static_cast<size_t>(w)] & rd[w]; bits; bits &= bits - 1) {
          --degree[static_cast<size_t>(w * 64 + std::countr_zero(bits))];
        }
      }
    });
  }
  return clique;
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
  std::vector<int> clique = greedyClique(n, words, adj);
  std::sort(clique.begin(), clique.end());
  return clique;
}

}  // namespace evermap::core
