#pragma once
// A registration oracle: stands in for loopclose-proc in measurement-level simulations by
// answering REGISTER_REQUEST from ground truth.
//
// It learns the ground-truth camera pose of every keyframe (from the simulator) and, from
// NODE_ADDED, which keyframe describes each map node. A request registers the query keyframe
//  - MODE_NODE: against the given node;
//  - MODE_GLOBAL: against the best `global_candidates` nodes near the query's true pose among
//    the nodes the mapper put on the requested floor (the appearance search), tried in order
//    of success probability.
// A registration between camera poses at distance d and view-angle difference a (angle
// between the optical axes) on the same true floor succeeds with probability
//   p = success_probability * exp(-½ (d / distance_scale_m)²) * exp(-½ (a / angle_scale_rad)²)
// (0 beyond max_distance_m or max_view_angle_rad, or across floors). A success returns
// node_T_query (camera frames) perturbed on the right by δ ~ N(0, diag(σt², σr²)),
//   σt = translation_sigma_m + translation_sigma_per_m * d,
//   σr = rotation_sigma_rad + rotation_sigma_per_rad * a,
// with that covariance. With probability false_match_rate_* per request the answer is a
// false match instead: STATUS_OK with a plausible but wrong node (global: a node of the floor
// away from the query, with a relative pose of 0.5-2.5 m and 0.1-0.5 rad as if the query
// were near it) or a wrong pose (node mode: 0.5-2.5 m and 0.1-0.5 rad off the truth), reported
// with an ordinary-looking covariance.
// Random draws come from the oracle's own stream, in request order.

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <evermap/node_added_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>

#include "core/common/expected.h"
#include "tools/sim/random.h"
#include "tools/sim/session_generator.h"

namespace evermap::sim {

struct OracleOptions {
  double max_distance_m = 5.0;
  double max_view_angle_rad = 1.0;
  double success_probability = 0.95;
  double distance_scale_m = 2.0;
  double angle_scale_rad = 0.5;
  int global_candidates = 3;
  double false_match_rate_node = 0.002;
  double false_match_rate_global = 0.01;
  double translation_sigma_m = 0.02;
  double translation_sigma_per_m = 0.01;
  double rotation_sigma_rad = 0.005;
  double rotation_sigma_per_rad = 0.01;
  int min_inliers = 20;
  int max_inliers = 250;
  double keyframe_window_s = 0.0;  // > 0: forget keyframes older than this behind the newest

  Status validate() const;
};

// Angle between the optical (z) axes of two camera poses (the oracle's a).
double viewAngle(const SE3d& a, const SE3d& b);

// A registration request against a node, with the truth: the distance and view angle between
// the two keyframes' camera poses and whether it came back as a true registration.
struct ReachSample {
  double distance_m = 0.0;
  double view_angle_rad = 0.0;
  bool ok = false;
};
// The oracle's success model fitted to what a registration (loopclose-proc's) did: the
// success_probability, distance_scale_m and angle_scale_rad of the largest likelihood
// (a grid of 0.05 / 0.1 m / 0.1 rad, then 0.01 / 0.02 m / 0.02 rad around its best), from
// the samples within the bounds' max_distance_m and max_view_angle_rad (beyond, the model
// says 0: those are counted apart).
struct ReachFit {
  double success_probability = 0.0;
  double distance_scale_m = 0.0;
  double angle_scale_rad = 0.0;
  double log_likelihood = 0.0;
  int64_t samples = 0;    // fitted
  int64_t beyond = 0;     // outside the bounds
  int64_t ok_beyond = 0;  // of which succeeded
};
ReachFit fitReach(const std::vector<ReachSample>& samples, const OracleOptions& bounds);

struct OracleSummary {
  int64_t keyframes = 0;
  int64_t nodes = 0;
  int64_t nodes_without_keyframe = 0;  // NODE_ADDED naming a keyframe the oracle never saw
  int64_t requests_node = 0;
  int64_t requests_global = 0;
  int64_t ok_node = 0;
  int64_t ok_global = 0;
  int64_t false_node = 0;
  int64_t false_global = 0;
  int64_t no_candidate = 0;
  int64_t too_few_inliers = 0;
  int64_t unknown_node = 0;
  int64_t unknown_keyframe = 0;
  int64_t malformed = 0;
  std::string text() const;  // one line per figure
};

class RegistrationOracle {
 public:
  struct Answer {
    register_result_t result;
    bool false_match = false;
  };

  RegistrationOracle(const OracleOptions& options, uint64_t seed);

  void addKeyframe(const KeyframeTruth& keyframe);
  // False (and counted) when the node's keyframe is unknown; a repeated node id is replaced.
  bool addNode(const node_added_t& node);
  register_result_t answer(const register_request_t& request) {
    return answerWithTruth(request).result;
  }
  // The answer and whether it is a false match (for tests and evaluation).
  Answer answerWithTruth(const register_request_t& request);

  double successProbability(double distance_m, double view_angle_rad) const;
  const OracleSummary& summary() const { return summary_; }

 private:
  struct Node {
    int64_t id = 0;
    SE3d world_T_cam;
    int true_floor = -1;
    int mapped_floor = -1;
  };
  struct CellKey {
    int floor;
    int64_t ix;
    int64_t iy;
    bool operator==(const CellKey&) const = default;
  };
  struct CellHash {
    size_t operator()(const CellKey& k) const;
  };

  const KeyframeTruth* findKeyframe(int64_t utime) const;
  CellKey cellOf(int floor, const Vec3& p) const;
  Answer nodeMode(const register_request_t& req, const KeyframeTruth& query);
  Answer globalMode(const register_request_t& req, const KeyframeTruth& query);
  void registerTrue(const Node& node, const KeyframeTruth& query, double p, register_result_t* r);
  void registerFalse(const Node& node, const SE3d& base, register_result_t* r);
  static register_result_t emptyResult(const register_request_t& req, int8_t status,
                                       const char* reason);

  OracleOptions o_;
  Random rng_;
  std::deque<KeyframeTruth> keyframes_;  // increasing utime
  std::vector<Node> nodes_;
  std::unordered_map<int64_t, size_t> node_index_;
  std::unordered_map<CellKey, std::vector<size_t>, CellHash> cells_;
  std::map<int, std::vector<size_t>> nodes_by_floor_;  // mapped floor -> nodes
  OracleSummary summary_;
};

}  // namespace evermap::sim
