#include "mapper-proc/mapper_options.h"

#include <cmath>

#include "core/solver/batch_solver.h"

namespace evermap::mapper {
namespace {

// "dcs:20", "none", "gnc" (its parameter 0: the χ² quantile): text parseRobustKernel reads back.
std::string kernelText(const solver::RobustKernel& k) {
  const std::string name = k.name();
  const std::string type = name.substr(0, name.find(':'));
  if (!k.active() || k.parameter == 0.0) return type;
  return type + ":" + option_text::ofDouble(k.parameter);
}

void declareKernel(OptionList& o, const std::string& key, solver::RobustKernel* kernel,
                   std::string doc) {
  o.custom<solver::RobustKernel>(key, kernel, solver::parseRobustKernel, kernelText,
                                 "none | pseudo-huber | cauchy | dcs | gnc [:parameter]",
                                 std::move(doc));
}

}  // namespace

void declareSolverOptions(OptionList& o, solver::IncrementalOptions* s) {
  using solver::Method;
  o.choice("method", &s->method,
           {{"gn", Method::kGaussNewton},
            {"dogleg", Method::kDogLeg},
            {"gauss-newton", Method::kGaussNewton},
            {"dl", Method::kDogLeg},
            {"powell", Method::kDogLeg}},
           "the incremental solver's step: Gauss-Newton or dog leg");
  o.add("batch_every", &s->batch_every, "updates", "a batch step every this many; 0: never")
      .nonNegative();
  o.add("wildfire_threshold", &s->wildfire_threshold, "m, rad",
        "back substitution stops at a change below this; 0: exact")
      .nonNegative();
  o.add("initial_trust_radius", &s->initial_trust_radius, "", "dog leg's first trust radius")
      .positive();
  o.add("recent_last", &s->recent_last, "variables", "ordered last in a batch step").nonNegative();
  o.add("background_batch_lag", &s->background_batch_lag, "updates",
        "a scheduled batch step is swapped in this many updates later; 0: in place")
      .nonNegative();
}

void MapperOptions::declareOptions(OptionList& o) {
  declarePlaces(o);
  declareSteps(o);
  declareClosures(o);
  declareRecovery(o);
  declareWarmRestart(o);
  o.nest("floor_gate.", &floor_gate);
  o.nest("tracker.", &tracker);
  o.nest("localize.", &localize);
  o.nest("solver.", &solver, declareSolverOptions);
}

void MapperOptions::declarePlaces(OptionList& o) {
  o.add("cell_size_m", &cell_size_m, "m", "edge of a floor's partition cell").positive();
  o.add("heading_bins", &heading_bins, "", "heading sectors of a cell").min(1);
  o.add("overlap_radius_cells", &overlap_radius_cells, "cells",
        "a node this near shows the same place; 0: the cells alone")
      .in(0.0, 3.0);
  o.add("overlap_heading_sectors", &overlap_heading_sectors, "sectors",
        "... and within this many heading sectors")
      .in(0.0, 1.0);
  o.add("footprints", &footprints,
        "a place registered from in an earlier session is mapped: no node there");
  o.add("floor_match_m", &floor_match_m, "m",
        "a ride ends on the map's floor within this of its measured height")
      .positive();
}

void MapperOptions::declareSteps(OptionList& o) {
  o.add("relocalization_checks", &relocalization_checks, "requests",
        "node-mode checks of a candidate placement while lost")
      .nonNegative();
  o.add("step_interval_s", &step_interval_s, "s", "steps at VO keyframes at most this often")
      .nonNegative();
  o.add("request_timeout_s", &request_timeout_s, "s", "an unanswered registration closes")
      .positive();
  o.add("session_gap_s", &session_gap_s, "s", "a VO gap this long starts a new session").positive();
  o.add("covariance_floor", &covariance_floor, "m^2, rad^2",
        "added to each constraint covariance's diagonal")
      .nonNegative();
  o.add("origin_sigma_m", &origin_sigma_m, "m", "prior on the first node, position").positive();
  o.add("origin_sigma_rad", &origin_sigma_rad, "rad", "prior on the first node, rotation")
      .positive();
  o.add("attitude_factors", &attitude_factors, "IMU roll/pitch factors on each node");
  o.add("height_factors", &height_factors, "floor height factors on each node");
  o.add("defer_merges", &defer_merges,
        "a constraint merging into an existing pair waits for the next consolidation");
  o.add("cell_refresh_per_step", &cell_refresh_per_step, "nodes",
        "partition index refreshed per step after a background batch")
      .min(1);
}

void MapperOptions::declareClosures(OptionList& o) {
  o.add("consistency_gate", &consistency_gate, "chi2(6)", "gate of one pair's constraints")
      .positive();
  o.add("recent_exclusion_s", &recent_exclusion_s, "s",
        "full graph: nodes this recent are no loop targets")
      .nonNegative();
  declareKernel(o, "loop_kernel", &loop_kernel, "kernel on a closure the map gate did not test");
  declareKernel(o, "vetted_loop_kernel", &vetted_loop_kernel,
                "kernel on a closure that passed the map gate");
  o.add("map_gate", &map_gate, "chi2(6)",
        "gate of a registration against the map's estimate; 0: off")
      .nonNegative();
  o.add("closure_partners", &closure_partners, "pairs",
        "beyond this many pairs per node a new pair needs information; 0: no bound, not 1")
      .nonNegative();
  o.add("saturated_closure_information", &saturated_closure_information, "nats",
        "the information a pair between saturated nodes needs")
      .nonNegative();
  o.add("closure_partner_sessions", &closure_partner_sessions, "sessions",
        "a node below closure_partners takes a pair freely in its first this many sessions; 0: "
        "always")
      .nonNegative();
}

void MapperOptions::declareRecovery(OptionList& o) {
  o.add("fuse_active_registration", &fuse_active_registration,
        "fuse a registration to the active node with delta (else keep the smaller det)");
  o.add("recovery_quiet_s", &recovery_quiet_s, "s",
        "a gate recovery needs a bridged gap or this long unconfirmed")
      .nonNegative();
  o.add("recovery_slack_m", &recovery_slack_m, "m", "a recovery's jump at most this ...")
      .nonNegative();
  o.add("recovery_drift_fraction", &recovery_drift_fraction, "",
        "... plus this fraction of the distance travelled since")
      .nonNegative();
}

void MapperOptions::declareWarmRestart(OptionList& o) {
  o.add("warm_restart_max_gap_s", &warm_restart_max_gap_s, "s",
        "a restored mapper resumes tracking after a gap up to this; 0: never")
      .nonNegative();
  o.add("warm_restart_speed_m_s", &warm_restart_speed_m_s, "m/s",
        "position sigma growth per second of the gap")
      .positive();
  o.add("warm_restart_turn_rad_s", &warm_restart_turn_rad_s, "rad/s",
        "heading sigma growth per second of the gap")
      .positive();
  o.add("warm_restart_node_sigma_m", &warm_restart_node_sigma_m, "m",
        "until confirmed, nodes only while delta's sigma is at most this")
      .nonNegative();
  o.add("warm_restart_bridge", &warm_restart_bridge, "VO's odometry bridges a restart's gap");
  o.add("warm_restart_bridge_max_gap_s", &warm_restart_bridge_max_gap_s, "s",
        "the longest gap the odometry bridge crosses")
      .nonNegative();
  o.add("warm_restart_wheel_wait_s", &warm_restart_wheel_wait_s, "s",
        "VO frames wait this long for a wheel bridge; 0: no wait")
      .in(0.0, 10.0);
  o.add("warm_restart_elevator_radius_m", &warm_restart_elevator_radius_m, "m",
        "a long gap near a known elevator is not resumed; 0: no guard")
      .nonNegative();
  o.add("warm_restart_ride_min_s", &warm_restart_ride_min_s, "s",
        "... a gap at least this long (a possible ride)")
      .nonNegative();
}

// Single-field ranges are declared above; these are the rules between fields.
Status MapperOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "mapper."); !s) return s;
  // 1 would test every new pair (a node has its odometry partner from the start).
  if (closure_partners == 1) return Error{"mapper.closure_partners: must be 0 (no bound) or >= 2"};
  if (auto s = tracker.validate(); !s) return s;
  return solver.validate();
}

}  // namespace evermap::mapper
