#include "core/solver/online_runner.h"

#include <set>

#include "core/solver/landmark_factors.h"

namespace evermap::solver {

OnlineRunner::OnlineRunner(const GraphFile& graph, const OnlineOptions& options)
    : graph_(graph), options_(options), solver_(options.solver) {
  std::set<Key> known = {firstPoseId(graph)};
  std::set<Key> known_landmarks;
  steps_.push_back(Step{firstPoseId(graph), -1, {}, {}, {}});
  size_t next_obs = 0;
  // Observations that came before edge `upto` in the file join the current step.
  auto takeObservations = [&](int upto) {
    for (;
         next_obs < graph.observations.size() && graph.observations[next_obs].edges_before <= upto;
         ++next_obs) {
      const int o = static_cast<int>(next_obs);
      steps_.back().observations.push_back(o);
      if (known_landmarks.insert(graph.observations[o].landmark).second) {
        steps_.back().new_landmarks.push_back(o);
      }
    }
  };
  for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
    takeObservations(e);
    const GraphEdge& edge = graph.edges[e];
    const bool has_from = known.count(edge.from) != 0;
    const bool has_to = known.count(edge.to) != 0;
    if (!has_from || !has_to) {
      // An edge between two unknown poses cannot be placed online; it joins the step of
      // the pose it introduces first and is initialised from the other end later.
      const Key fresh = has_from ? edge.to : edge.from;
      steps_.push_back(Step{fresh, e, {}, {}, {}});
      known.insert(fresh);
      if (!has_from && !has_to) {
        steps_.push_back(Step{edge.to, e, {}, {}, {}});
        known.insert(edge.to);
      }
    }
    steps_.back().edges.push_back(e);
  }
  takeObservations(static_cast<int>(graph.edges.size()));
}

Expected<UpdateResult> OnlineRunner::step() {
  const Step& s = steps_[next_];
  UpdateRequest request;
  const int d = graph_.dimension;
  PoseValue init = d == 2 ? PoseValue::planar(core::SE2d()) : PoseValue::spatial(core::SE3d());
  if (s.init_edge >= 0) {
    const GraphEdge& e = graph_.edges[s.init_edge];
    const bool forward = e.to == s.new_pose;
    const Key base_key = forward ? e.from : e.to;
    if (solver_.graph().values().contains(base_key)) {
      const PoseValue base = solver_.estimate(base_key);
      if (d == 2) {
        init = PoseValue::planar(forward ? base.se2 * e.measurement.se2
                                         : base.se2 * e.measurement.se2.inverse());
      } else {
        init = PoseValue::spatial(forward ? base.se3 * e.measurement.se3
                                          : base.se3 * e.measurement.se3.inverse());
      }
    }
  }
  request.new_variables.emplace_back(s.new_pose, init);
  if (next_ == 0 && options_.build.anchor) {
    request.new_factors.push_back(makeAnchorFactor(s.new_pose, d));
  }
  for (int o : s.new_landmarks) {
    const GraphObservation& ob = graph_.observations[o];
    PoseValue base;
    if (ob.pose == s.new_pose) {
      base = init;
    } else if (solver_.graph().values().contains(ob.pose)) {
      base = solver_.estimate(ob.pose);
    } else {
      return makeError(graph_.path, ":", ob.line, ": landmark observed from pose ", ob.pose,
                       " before that pose exists");
    }
    if (base.isPoint() || solver_.graph().values().contains(ob.landmark) ||
        ob.landmark == s.new_pose) {
      return makeError(graph_.path, ":", ob.line, ": landmark ", ob.landmark,
                       " is observed from a landmark or has a pose's id");
    }
    request.new_variables.emplace_back(
        ob.landmark, observationInitialValue(base, ob.measured, ob.pose_T_sensor));
  }
  for (int o : s.observations) {
    FactorPtr f = makeObservationFactor(graph_, graph_.observations[o]);
    if (options_.build.kernel.active() && options_.build.robust_odometry) {
      f->setKernel(kernelForFactor(options_.build.kernel, f->dim()));
    }
    request.new_factors.push_back(std::move(f));
  }
  for (int e : s.edges) {
    const GraphEdge& edge = graph_.edges[e];
    if (options_.build.objective == Objective::kNative && !edge.positiveDefinite()) {
      return makeError(graph_.path, ":", edge.line,
                       ": information matrix is not positive "
                       "definite (see resolveIndefiniteInformation)");
    }
    FactorPtr f = makeEdgeFactor(graph_, edge, options_.build.objective);
    if (options_.build.kernel.active() &&
        (options_.build.robust_odometry || !isOdometryEdge(edge))) {
      f->setKernel(kernelForFactor(options_.build.kernel, f->dim()));
    }
    request.new_factors.push_back(std::move(f));
  }
  ++next_;
  auto r = solver_.update(request);
  if (!r.ok()) return makeError(graph_.path, ": step ", next_ - 1, ": ", r.error().message);
  return r;
}

}  // namespace evermap::solver
