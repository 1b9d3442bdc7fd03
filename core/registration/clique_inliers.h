#pragma once
// Inlier detection without a motion hypothesis (Howard, "Real-time stereo visual odometry for
// autonomous ground vehicles", IROS 2008, section III-C; Huang et al. 2011 section 3.5): a
// rigid motion preserves distances, so two correct matches (i, j) satisfy
//   | L_a - L_b | < threshold_m + sigmas * σ_L,    L_f = ||p_f[i] - p_f[j]|| in frame f,
// where σ_L is the first-order standard deviation of L_a - L_b caused by stereo depth noise
// (without depth sigmas: σ_L = 0, the fixed threshold of FOVIS without stereo).
// A stereo point's depth error moves it along its ray from the left camera, δp = p δz / z,
// so with e = (p[i] - p[j]) / L (the unit direction of the pair) and s_k the standard
// deviation of the depth of point k,
//   σ_L_f² = (e·p[i] s_i / z_i)² + (e·p[j] s_j / z_j)²,    σ_L² = σ_L_a² + σ_L_b².
// Only the component of the depth error along the pair counts: a far pair seen side by side
// keeps its distance however uncertain its depth (the same observation as Hirschmüller,
// Innocent & Garibaldi, "Fast, unconstrained camera motion estimation from stereo without
// tracking and robust statistics", ICARCV 2002, whose test FOVIS uses on stereo).
// The matches are the vertices of a graph with an edge for every consistent pair; the inliers
// are a maximum clique of it, found greedily as FOVIS does: start from the vertex of highest
// degree, then repeatedly add the candidate (adjacent to every member so far) that has the
// most neighbours among the remaining candidates.
//
// Cost: O(n^2) pair tests and O(n^2 k / 64) for a clique of size k, with bit sets.

#include <vector>

#include <Eigen/Core>

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct CliqueOptions {
  // Change of a pairwise distance (metres) always counted as consistent (FOVIS: 0.1 m).
  double threshold_m = 0.1;
  // Standard deviations of the depth noise added to it.
  double sigmas = 3.0;

  void declareOptions(OptionList& o);
};

// Indices (into the match list) of a maximum clique of mutually consistent matches, where
// match k pairs points_a[k] with points_b[k]; depth_sigma_a_m[k] and depth_sigma_b_m[k]
// (metres) are the standard deviations of the depths of its two points, or both lists are
// empty for the fixed threshold only. Lists of equal length (checked, aborts otherwise).
// Ascending.
std::vector<int> maxConsistentClique(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<double>& depth_sigma_a_m,
                                     const std::vector<double>& depth_sigma_b_m,
                                     const CliqueOptions& options);

}  // namespace evermap::core
