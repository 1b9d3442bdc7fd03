#pragma once
// Inlier detection without a motion hypothesis (Howard, "Real-time stereo visual odometry for
// autonomous ground vehicles", IROS 2008, section III-C; Huang et al. 2011 section 3.5): a
// rigid motion preserves distances, so two correct matches (i, j) satisfy
//   | ||p_a[i] - p_a[j]|| - ||p_b[i] - p_b[j]|| | < threshold.
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
  // Largest change of a pairwise distance (metres) still counted as consistent.
  double threshold_m = 0.1;
  // Per pair, the threshold also grows by this fraction of the larger depth of the pair
  // (stereo depth error grows with depth); 0 gives FOVIS's fixed threshold.
  double threshold_per_depth = 0.0;
};

// Indices (into the match list) of a maximum clique of mutually consistent matches, where
// match k pairs points_a[k] with points_b[k] (the two lists have equal length). Ascending.
std::vector<int> maxConsistentClique(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const CliqueOptions& options);

}  // namespace evermap::core
