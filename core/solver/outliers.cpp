#include "core/solver/outliers.h"

#include <algorithm>
#include <map>
#include <optional>
#include <random>

#include "core/common/enum_names.h"
#include "core/solver/graph_problem.h"

namespace evermap::solver {

Expected<OutlierMode> parseOutlierMode(const std::string& text) {
  if (text == "random") return OutlierMode::kRandom;
  if (text == "local") return OutlierMode::kLocal;
  if (text == "group" || text == "grouped") return OutlierMode::kGroup;
  return makeError("outlier mode '", text, "': expected random, local or group");
}

const char* outlierModeName(OutlierMode mode) {
  static constexpr EnumNames<OutlierMode, 3> kNames{{
      {OutlierMode::kRandom, "random"},
      {OutlierMode::kLocal, "local"},
      {OutlierMode::kGroup, "group"},
  }};
  return nameOf(kNames, mode);
}

bool isSyntheticOutlier(const GraphEdge& edge) { return edge.line == 0; }

namespace {

class Generator {
 public:
  Generator(const GraphFile& graph, const OutlierOptions& o) : g_(graph), o_(o), rng_(o.seed) {
    for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
      const GraphEdge& edge = graph.edges[e];
      for (Key k : {edge.from, edge.to}) {
        if (intro_.emplace(k, e).second) poses_.push_back(k);
      }
      if (edge.to == edge.from + 1) odometry_.emplace(edge.from, edge.measurement);
      if (edge.from == edge.to + 1) odometry_.emplace(edge.to, inverse(edge.measurement));
      if (!isOdometryEdge(edge)) loops_.push_back(e);
    }
    if (loops_.empty()) {
      for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) loops_.push_back(e);
    }
    std::sort(poses_.begin(), poses_.end());
  }

  // (insert after edge index, edge) pairs.
  std::vector<std::pair<int, GraphEdge>> generate() {
    std::vector<std::pair<int, GraphEdge>> out;
    if (poses_.size() < 4) return out;
    int attempts = 0;
    while (static_cast<int>(out.size()) < o_.count && ++attempts < 100 * (o_.count + 10)) {
      if (o_.mode == OutlierMode::kGroup) {
        addGroup(&out);
      } else {
        addSingle(&out);
      }
    }
    return out;
  }

 private:
  PoseValue randomRelativePose() {
    std::normal_distribution<double> t(0.0, o_.translation_sigma_m);
    std::normal_distribution<double> r(0.0, o_.rotation_sigma_rad);
    if (g_.dimension == 2) return PoseValue::planar(core::SE2d(t(rng_), t(rng_), r(rng_)));
    const core::Vec3 omega(r(rng_), r(rng_), r(rng_));
    return PoseValue::spatial(
        core::SE3d(core::SO3d::exp(omega), core::Vec3(t(rng_), t(rng_), t(rng_))));
  }

  GraphEdge edge(Key a, Key b, const PoseValue& a_T_b) {
    std::uniform_int_distribution<size_t> pick_loop(0, loops_.size() - 1);
    const GraphEdge& like = g_.edges[loops_[pick_loop(rng_)]];
    GraphEdge e;
    e.from = a;
    e.to = b;
    e.measurement = a_T_b;
    e.sqrt_information = like.sqrt_information;
    e.indefinite_information = like.indefinite_information;
    e.line = 0;
    return e;
  }

  void push(std::vector<std::pair<int, GraphEdge>>* out, GraphEdge e) {
    const int after = std::max(intro_.at(e.from), intro_.at(e.to));
    out->emplace_back(after, std::move(e));
  }

  void addSingle(std::vector<std::pair<int, GraphEdge>>* out) {
    std::uniform_int_distribution<size_t> pick(0, poses_.size() - 1);
    const size_t i = pick(rng_);
    size_t j = pick(rng_);
    if (o_.mode == OutlierMode::kLocal) {
      std::uniform_int_distribution<int> ahead(2, std::max(2, o_.local_window));
      j = std::min(poses_.size() - 1, i + ahead(rng_));
    }
    const Key a = std::min(poses_[i], poses_[j]);
    const Key b = std::max(poses_[i], poses_[j]);
    if (b - a < 2) return;
    push(out, edge(a, b, randomRelativePose()));
  }

  // a_T_{a+n} chained from odometry, or nothing when a link is missing.
  std::optional<PoseValue> chain(Key a, int n) const {
    PoseValue T =
        g_.dimension == 2 ? PoseValue::planar(core::SE2d()) : PoseValue::spatial(core::SE3d());
    for (int k = 0; k < n; ++k) {
      const auto it = odometry_.find(a + k);
      if (it == odometry_.end()) return std::nullopt;
      T = compose(T, it->second);
    }
    return T;
  }

  void addGroup(std::vector<std::pair<int, GraphEdge>>* out) {
    const int n = std::min(o_.group_size, o_.count - static_cast<int>(out->size()));
    std::uniform_int_distribution<size_t> pick(0, poses_.size() - 1);
    Key a = poses_[pick(rng_)];
    Key b = poses_[pick(rng_)];
    if (a > b) std::swap(a, b);
    if (b - a < n + 2) return;  // the two stretches must not overlap or touch
    if (!intro_.count(a + n - 1) || !intro_.count(b + n - 1)) return;
    const PoseValue T = randomRelativePose();  // the false a_T_b all members agree on
    std::vector<GraphEdge> members;
    for (int k = 0; k < n; ++k) {
      const auto a_T_ak = chain(a, k);
      const auto b_T_bk = chain(b, k);
      if (!a_T_ak || !b_T_bk) return;
      members.push_back(edge(a + k, b + k, compose(compose(inverse(*a_T_ak), T), *b_T_bk)));
    }
    for (GraphEdge& e : members) push(out, std::move(e));
  }

  const GraphFile& g_;
  const OutlierOptions& o_;
  std::mt19937 rng_;
  std::map<Key, int> intro_;  // edge index at which each pose first appears
  std::vector<Key> poses_;
  std::map<Key, PoseValue> odometry_;  // i → i_T_{i+1}
  std::vector<int> loops_;
};

}  // namespace

GraphFile addFalseLoopClosures(const GraphFile& graph, const OutlierOptions& options) {
  GraphFile out = graph;
  if (options.count <= 0 || graph.edges.empty()) return out;
  auto inserts = Generator(graph, options).generate();
  std::stable_sort(inserts.begin(), inserts.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  out.edges.clear();
  size_t next = 0;
  // new_index[e]: where file edge e lands, so landmark observations keep their place.
  std::vector<int> new_index(graph.edges.size() + 1);
  for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
    new_index[e] = static_cast<int>(out.edges.size());
    out.edges.push_back(graph.edges[e]);
    while (next < inserts.size() && inserts[next].first == e) {
      out.edges.push_back(inserts[next++].second);
    }
  }
  new_index[graph.edges.size()] = static_cast<int>(out.edges.size());
  for (GraphObservation& o : out.observations) o.edges_before = new_index[o.edges_before];
  return out;
}

}  // namespace evermap::solver
