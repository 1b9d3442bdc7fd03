#pragma once
// Inlier detection without a motion hypothesis (Howard, "Real-time stereo visual odometry for
// autonomous ground vehicles", IROS 2008, section III-C; Huang et al. 2011 section 3.5): a
// rigid motion preserves distances, so two correct matches (i, j) satisfy
//   | ||p_a[i] - p_a[j]|| - ||p_b[i] - p_b[j]|| | < threshold_m + sigmas * sqrt(s_i² + s_j²),
// where s_k is the standard deviation of the depths of match k (stereo depth error grows with
// the square of the depth; without s, the fixed threshold of FOVIS).
// The matches are the vertices of a graph with an edge for every consistent pair; the inliers
// are a maximum clique of it, found greedily as FOVIS does: start from the vertex of highest
// degree, then repeatedly add the candidate (adjacent to every member so far) that has the
// most neighbours among the remaining candidates.
//
// Cost: O(n^2) pair tests and O(n^2 k / 64) for a clique of size k, with bit sets.

#include <vector>

#include <Eigen/Core>

namespace evermap::core {

struct CliqueOptions {
  // Change of a pairwise distance (metres) always counted as consistent (FOVIS: 0.1 m).
  double threshold_m = 0.1;
  // Standard deviations of the depth noise added to it.
  double sigmas = 3.0;
};

// Indices (into the match list) of a maximum clique of mutually consistent matches, where
// match k pairs points_a[k] with points_b[k]; depth_sigma_m[k] (metres) is the standard
// deviation of the depth of match k (of both its points together), or the list is empty for
// the fixed threshold only. Lists of equal length (checked, aborts otherwise). Ascending.
std::vector<int> maxConsistentClique(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<double>& depth_sigma_m,
                                     const CliqueOptions& options);

}  // namespace evermap::core
