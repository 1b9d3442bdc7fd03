#include "tools/sim/registration_oracle.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "tools/sim/sim_message_conversions.h"

namespace evermap::sim {
namespace {

void eraseValue(std::vector<size_t>& v, size_t value) {
  v.erase(std::remove(v.begin(), v.end(), value), v.end());
}

// Log-likelihood of the samples under p = P exp(-½ (d/D)²) exp(-½ (a/A)²).
double reachLogLikelihood(const std::vector<ReachSample>& samples, double P, double D, double A) {
  double ll = 0.0;
  for (const ReachSample& s : samples) {
    const double u = s.distance_m / D, v = s.view_angle_rad / A;
    const double p = std::clamp(P * std::exp(-0.5 * (u * u + v * v)), 1e-9, 1.0 - 1e-9);
    ll += s.ok ? std::log(p) : std::log1p(-p);
  }
  return ll;
}

// An accepted registration to node `node_id`: the pose and a diagonal covariance of
// translation sigma `st` and rotation sigma `sr`.
void acceptResult(int64_t node_id, const SE3d& node_T_query, double st, double sr,
                  register_result_t* r) {
  r->status = register_result_t::STATUS_OK;
  r->node_id = node_id;
  writePose(node_T_query, r->translation, r->orientation);
  core::Mat6 cov = core::Mat6::Zero();
  cov.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  writeCovariance(cov, r->covariance);
}

}  // namespace

double viewAngle(const SE3d& a, const SE3d& b) {
  const Vec3 za = a.so3() * Vec3::UnitZ();
  const Vec3 zb = b.so3() * Vec3::UnitZ();
  return std::acos(std::clamp(za.dot(zb), -1.0, 1.0));
}

ReachFit fitReach(const std::vector<ReachSample>& samples, const OracleOptions& bounds) {
  ReachFit fit;
  std::vector<ReachSample> within;
  for (const ReachSample& s : samples) {
    if (!std::isfinite(s.distance_m) || !std::isfinite(s.view_angle_rad)) continue;
    if (s.distance_m > bounds.max_distance_m || s.view_angle_rad > bounds.max_view_angle_rad) {
      ++fit.beyond;
      fit.ok_beyond += s.ok ? 1 : 0;
      continue;
    }
    within.push_back(s);
  }
  fit.samples = static_cast<int64_t>(within.size());
  if (within.empty()) return fit;
  // A coarse grid, then a finer one around its best point.
  struct Grid {
    double lo, hi, step;
  };
  auto search = [&](Grid gp, Grid gd, Grid ga) {
    for (double P = gp.lo; P <= gp.hi + 1e-9; P += gp.step)
      for (double D = gd.lo; D <= gd.hi + 1e-9; D += gd.step)
        for (double A = ga.lo; A <= ga.hi + 1e-9; A += ga.step) {
          if (P <= 0.0 || P > 1.0 || D <= 0.0 || A <= 0.0) continue;
          const double ll = reachLogLikelihood(within, P, D, A);
          if (ll > fit.log_likelihood) {
            fit.log_likelihood = ll;
            fit.success_probability = P;
            fit.distance_scale_m = D;
            fit.angle_scale_rad = A;
          }
        }
  };
  fit.log_likelihood = -std::numeric_limits<double>::infinity();
  search({0.5, 1.0, 0.05}, {0.2, 4.0, 0.1}, {0.1, 1.5, 0.1});
  const ReachFit coarse = fit;
  search({coarse.success_probability - 0.05, coarse.success_probability + 0.05, 0.01},
         {coarse.distance_scale_m - 0.1, coarse.distance_scale_m + 0.1, 0.02},
         {coarse.angle_scale_rad - 0.1, coarse.angle_scale_rad + 0.1, 0.02});
  return fit;
}

Status OracleOptions::validate() const {
  if (!(max_distance_m > 0.0)) return makeError("max_distance_m: must be > 0");
  if (!(max_view_angle_rad > 0.0)) return makeError("max_view_angle_rad: must be > 0");
  if (!(success_probability >= 0.0 && success_probability <= 1.0)) {
    return makeError("success_probability: must be in [0, 1]");
  }
  if (!(distance_scale_m > 0.0 && angle_scale_rad > 0.0)) {
    return makeError("distance_scale_m: distance and angle scales must be > 0");
  }
  if (global_candidates < 1) return makeError("global_candidates: must be >= 1");
  for (double r : {false_match_rate_node, false_match_rate_global}) {
    if (!(r >= 0.0 && r <= 1.0))
      return makeError("false_match_rate_node: false-match rates must be in [0, 1]");
  }
  for (double s :
       {translation_sigma_m, translation_sigma_per_m, rotation_sigma_rad, rotation_sigma_per_rad}) {
    if (!(s >= 0.0)) return makeError("translation_sigma_m: noise parameters must be >= 0");
  }
  if (min_inliers < 0 || max_inliers < min_inliers) {
    return makeError("min_inliers: need 0 <= min_inliers <= max_inliers");
  }
  if (!(keyframe_window_s >= 0.0)) return makeError("keyframe_window_s: must be >= 0");
  return Ok{};
}

std::string OracleSummary::text() const {
  std::ostringstream o;
  o << "oracle keyframes known      " << keyframes << "\n"
    << "oracle nodes                " << nodes << " (" << nodes_without_keyframe
    << " without keyframe)\n"
    << "oracle node requests        " << requests_node << ": ok " << ok_node << " (false "
    << false_node << ")\n"
    << "oracle global requests      " << requests_global << ": ok " << ok_global << " (false "
    << false_global << ")\n"
    << "oracle failures             no candidate " << no_candidate << ", too few inliers "
    << too_few_inliers << ", unknown node " << unknown_node << ", unknown keyframe "
    << unknown_keyframe << ", malformed " << malformed << "\n";
  return o.str();
}

size_t RegistrationOracle::CellHash::operator()(const CellKey& k) const {
  uint64_t h = mixSeed(static_cast<uint64_t>(k.ix), static_cast<uint64_t>(k.iy));
  return static_cast<size_t>(mixSeed(h, static_cast<uint64_t>(k.floor) + 7));
}

RegistrationOracle::RegistrationOracle(const OracleOptions& options, uint64_t seed)
    : o_(options), rng_(seed) {}

void RegistrationOracle::addKeyframe(const KeyframeTruth& k) {
  ++summary_.keyframes;
  if (keyframes_.empty() || keyframes_.back().utime < k.utime) {
    keyframes_.push_back(k);
  } else {
    auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), k.utime,
                               [](const KeyframeTruth& a, int64_t t) { return a.utime < t; });
    if (it != keyframes_.end() && it->utime == k.utime)
      *it = k;
    else
      keyframes_.insert(it, k);
  }
  if (o_.keyframe_window_s > 0.0) {
    const auto window = static_cast<int64_t>(o_.keyframe_window_s * 1e6);
    while (keyframes_.front().utime < keyframes_.back().utime - window) keyframes_.pop_front();
  }
}

const KeyframeTruth* RegistrationOracle::findKeyframe(int64_t utime) const {
  auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), utime,
                             [](const KeyframeTruth& a, int64_t t) { return a.utime < t; });
  if (it == keyframes_.end() || it->utime != utime) return nullptr;
  return &*it;
}

RegistrationOracle::CellKey RegistrationOracle::cellOf(int floor, const Vec3& p) const {
  return CellKey{floor, static_cast<int64_t>(std::floor(p.x() / o_.max_distance_m)),
                 static_cast<int64_t>(std::floor(p.y() / o_.max_distance_m))};
}

bool RegistrationOracle::addNode(const node_added_t& m) {
  const KeyframeTruth* k = findKeyframe(m.keyframe_utime);
  if (!k) {
    ++summary_.nodes_without_keyframe;
    return false;
  }
  Node n{m.node_id, k->world_T_cam, k->floor, m.floor};
  if (auto it = node_index_.find(m.node_id); it != node_index_.end()) {
    const size_t i = it->second;
    eraseValue(cells_[cellOf(nodes_[i].mapped_floor, nodes_[i].world_T_cam.translation())], i);
    eraseValue(nodes_by_floor_[nodes_[i].mapped_floor], i);
    nodes_[i] = n;
  } else {
    node_index_[m.node_id] = nodes_.size();
    nodes_.push_back(n);
    ++summary_.nodes;
  }
  const size_t i = node_index_[m.node_id];
  cells_[cellOf(n.mapped_floor, n.world_T_cam.translation())].push_back(i);
  nodes_by_floor_[n.mapped_floor].push_back(i);
  return true;
}

double RegistrationOracle::successProbability(double d, double a) const {
  if (d > o_.max_distance_m || a > o_.max_view_angle_rad) return 0.0;
  const double u = d / o_.distance_scale_m;
  const double v = a / o_.angle_scale_rad;
  return o_.success_probability * std::exp(-0.5 * (u * u + v * v));
}

register_result_t RegistrationOracle::emptyResult(const register_request_t& req, int8_t status,
                                                  const char* reason) {
  register_result_t r{};
  r.utime = req.utime;
  r.request_id = req.request_id;
  r.keyframe_utime = req.keyframe_utime;
  r.status = status;
  r.node_id = -1;
  r.orientation[0] = 1.0;
  r.reason = reason;
  return r;
}

void RegistrationOracle::registerTrue(const Node& node, const KeyframeTruth& query, double p,
                                      register_result_t* r) {
  const SE3d truth = node.world_T_cam.inverse() * query.world_T_cam;
  const double d = truth.translation().norm();
  const double a = viewAngle(node.world_T_cam, query.world_T_cam);
  const double st = o_.translation_sigma_m + o_.translation_sigma_per_m * d;
  const double sr = o_.rotation_sigma_rad + o_.rotation_sigma_per_rad * a;
  core::Vec6 delta;
  for (int i = 0; i < 6; ++i) delta[i] = (i < 3 ? st : sr) * rng_.normal();
  const SE3d measured = (st > 0.0 || sr > 0.0) ? truth * SE3d::exp(delta) : truth;
  acceptResult(node.id, measured, st, sr, r);
  r->num_inliers = o_.min_inliers + static_cast<int32_t>((o_.max_inliers - o_.min_inliers) * p *
                                                         rng_.uniform(0.7, 1.0));
  r->score = std::clamp(p * rng_.uniform(0.8, 1.0), 0.0, 1.0);
  r->reason.clear();
}

void RegistrationOracle::registerFalse(const Node& node, const SE3d& base, register_result_t* r) {
  // A wrong relative pose that looks like an ordinary registration: `base` moved by a
  // horizontal offset in the camera's x-z plane and turned about its (vertical) y axis.
  const double heading = rng_.uniform(-std::numbers::pi, std::numbers::pi);
  const double dist = rng_.uniform(0.5, 2.5);
  const double turn = (rng_.bernoulli(0.5) ? 1.0 : -1.0) * rng_.uniform(0.1, 0.5);
  const SE3d wrong = base * SE3d(core::SO3d::exp(Vec3(0.0, turn, 0.0)),
                                 Vec3(dist * std::cos(heading), 0.0, dist * std::sin(heading)));
  const double st = o_.translation_sigma_m + o_.translation_sigma_per_m * dist;
  const double sr = o_.rotation_sigma_rad + o_.rotation_sigma_per_rad * std::abs(turn);
  acceptResult(node.id, wrong, st, sr, r);
  r->num_inliers = o_.min_inliers + static_cast<int32_t>(rng_.integer(0, 15));
  r->score = rng_.uniform(0.2, 0.5);
  r->reason.clear();
}

RegistrationOracle::Answer RegistrationOracle::answerWithTruth(const register_request_t& req) {
  if (req.mode != register_request_t::MODE_NODE && req.mode != register_request_t::MODE_GLOBAL) {
    ++summary_.malformed;
    return {emptyResult(req, register_result_t::STATUS_MALFORMED, "unknown mode"), false};
  }
  const KeyframeTruth* query = findKeyframe(req.keyframe_utime);
  if (req.mode == register_request_t::MODE_NODE)
    ++summary_.requests_node;
  else
    ++summary_.requests_global;
  if (!query) {
    ++summary_.unknown_keyframe;
    return {
        emptyResult(req, register_result_t::STATUS_UNKNOWN_KEYFRAME, "query keyframe not known"),
        false};
  }
  Answer a =
      req.mode == register_request_t::MODE_NODE ? nodeMode(req, *query) : globalMode(req, *query);
  const bool node_mode = req.mode == register_request_t::MODE_NODE;
  switch (a.result.status) {
    case register_result_t::STATUS_OK:
      (node_mode ? summary_.ok_node : summary_.ok_global) += 1;
      if (a.false_match) (node_mode ? summary_.false_node : summary_.false_global) += 1;
      break;
    case register_result_t::STATUS_NO_CANDIDATE:
      ++summary_.no_candidate;
      break;
    case register_result_t::STATUS_TOO_FEW_INLIERS:
      ++summary_.too_few_inliers;
      break;
    case register_result_t::STATUS_UNKNOWN_NODE:
      ++summary_.unknown_node;
      break;
    default:
      break;
  }
  return a;
}

RegistrationOracle::Answer RegistrationOracle::nodeMode(const register_request_t& req,
                                                        const KeyframeTruth& query) {
  const auto it = node_index_.find(req.target_node_id);
  if (it == node_index_.end()) {
    return {emptyResult(req, register_result_t::STATUS_UNKNOWN_NODE, "target node not known"),
            false};
  }
  const Node& node = nodes_[it->second];
  Answer a{emptyResult(req, register_result_t::STATUS_TOO_FEW_INLIERS, "too few inliers"), false};
  a.result.node_id = node.id;
  if (rng_.bernoulli(o_.false_match_rate_node)) {
    registerFalse(node, node.world_T_cam.inverse() * query.world_T_cam, &a.result);
    a.false_match = true;
    return a;
  }
  const double d = (node.world_T_cam.translation() - query.world_T_cam.translation()).norm();
  const double p = node.true_floor == query.floor
                       ? successProbability(d, viewAngle(node.world_T_cam, query.world_T_cam))
                       : 0.0;
  if (rng_.bernoulli(p)) registerTrue(node, query, p, &a.result);
  return a;
}

RegistrationOracle::Answer RegistrationOracle::globalMode(const register_request_t& req,
                                                          const KeyframeTruth& query) {
  // The nodes the appearance search may return: those the mapper put on the requested floor.
  std::vector<int> floors;
  if (req.floor >= 0) {
    if (nodes_by_floor_.count(req.floor) && !nodes_by_floor_[req.floor].empty())
      floors.push_back(req.floor);
  } else {
    for (const auto& [f, list] : nodes_by_floor_) {
      if (!list.empty()) floors.push_back(f);
    }
  }
  if (floors.empty()) {
    return {emptyResult(req, register_result_t::STATUS_NO_CANDIDATE, "no node on the floor"),
            false};
  }
  Answer a{emptyResult(req, register_result_t::STATUS_NO_CANDIDATE, "no candidate"), false};
  const Vec3 q = query.world_T_cam.translation();
  if (rng_.bernoulli(o_.false_match_rate_global)) {
    // A plausible but wrong node: one of the floor's nodes that is not near the query.
    const std::vector<size_t>& pool =
        nodes_by_floor_[floors[rng_.index(static_cast<int64_t>(floors.size()))]];
    size_t pick = pool[rng_.index(static_cast<int64_t>(pool.size()))];
    for (int tries = 0; tries < 16; ++tries) {
      const Node& n = nodes_[pick];
      if (n.true_floor != query.floor ||
          (n.world_T_cam.translation() - q).norm() > o_.max_distance_m)
        break;
      pick = pool[rng_.index(static_cast<int64_t>(pool.size()))];
    }
    // Close to the wrong node, as if the query were there.
    registerFalse(nodes_[pick], SE3d(), &a.result);
    a.false_match = true;
    return a;
  }
  struct Candidate {
    double p;
    size_t node;
  };
  std::vector<Candidate> candidates;
  for (int f : floors) {
    const CellKey c = cellOf(f, q);
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(CellKey{f, c.ix + dx, c.iy + dy});
        if (it == cells_.end()) continue;
        for (size_t i : it->second) {
          const Node& n = nodes_[i];
          if (n.true_floor != query.floor) continue;
          const double d = (n.world_T_cam.translation() - q).norm();
          const double p = successProbability(d, viewAngle(n.world_T_cam, query.world_T_cam));
          if (p > 0.0) candidates.push_back(Candidate{p, i});
        }
      }
    }
  }
  if (candidates.empty()) return a;
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& x, const Candidate& y) {
    return x.p != y.p ? x.p > y.p : nodes_[x.node].id < nodes_[y.node].id;
  });
  if (static_cast<int>(candidates.size()) > o_.global_candidates)
    candidates.resize(o_.global_candidates);
  for (const Candidate& c : candidates) {
    if (rng_.bernoulli(c.p)) {
      registerTrue(nodes_[c.node], query, c.p, &a.result);
      return a;
    }
  }
  a.result.status = register_result_t::STATUS_TOO_FEW_INLIERS;
  a.result.node_id = nodes_[candidates.front().node].id;
  a.result.reason = "candidates found, too few inliers";
  return a;
}

}  // namespace evermap::sim
