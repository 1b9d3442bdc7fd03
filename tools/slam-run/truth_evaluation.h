#pragma once
// evermap-slam-run's figures against the ground truth of its logs (GROUND_TRUTH): which
// accepted closures are false, how far each registration is off, the registration's reach,
// the nodes a session placed where an earlier one had one; and the per-hour cost figures.

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "core/geometry/se3.h"
#include "mapper-proc/mapper.h"
#include "tools/pipeline-eval/map_evaluation.h"
#include "tools/sim/registration_oracle.h"
#include "tools/slam-run/slam_runner.h"

namespace evermap::slam_run {

// The frames' figures by hour of run time (sessions end to end).
std::vector<HourFigures> hourFigures(const std::vector<SlamRunner::FrameRow>& frames);

// The true body pose of each node whose keyframe the truth covers, by node id.
std::map<int64_t, core::SE3d> nodeTruth(const mapper::Mapper& m, const mapper::RunTruth& truth);

// The nodes with truth, with the true floor at their keyframes (`truth_floor`: utime ->
// (floor, session) of the GROUND_TRUTH samples).
std::vector<SlamRunSummary::NodeRow> nodeRows(
    const mapper::Mapper& m, const std::map<int64_t, core::SE3d>& node_truth,
    const std::map<int64_t, std::pair<int, int>>& truth_floor);

// Accepted loop closures off the truth by more than `max_m` or `max_deg`; `with_truth`
// counts those both of whose nodes have truth.
int64_t falseClosures(const mapper::Mapper& m, const std::map<int64_t, core::SE3d>& node_truth,
                      double max_m, double max_deg, int64_t* with_truth);

// Fills the row's errors against the truth (error_*, nees, delta_*) where the truth covers
// its keyframes.
void scoreRegistration(const mapper::RunTruth& truth, SlamRunner::RegistrationRow* row);

// Every node-mode request on one floor, answered or not (registration rows scored first):
// distance and view angle of the two cameras, and whether a true registration came back.
std::vector<sim::ReachSample> registrationReach(
    const std::vector<SlamRunner::RegistrationRow>& rows, const mapper::RunTruth& truth,
    const core::SE3d& body_T_cam, double max_m, double max_deg);

// SessionSummary::nodes_in_mapped_area of each session: its nodes within 1 m and π/8 of an
// earlier session's node, on the same floor (true poses).
void countNodesInMappedArea(const mapper::Mapper& m,
                            const std::map<int64_t, core::SE3d>& node_truth,
                            std::vector<SessionSummary>* sessions);

}  // namespace evermap::slam_run
