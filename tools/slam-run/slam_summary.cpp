#include <algorithm>
#include <iterator>
#include <sstream>
#include <utility>

#include "tools/slam-run/slam_runner.h"

// SlamRunSummary::text(): the summary.txt that evermap-slam-run prints.

namespace evermap::slam_run {

std::string SlamRunSummary::text() const {
  std::ostringstream s;
  s << "sessions " << sessions.size() << "\ndata_s " << data_s << "\nwall_s " << wall_s
    << "\nrealtime_factor " << (wall_s > 0 ? data_s / wall_s : 0.0) << "\npeak_rss_mb "
    << peak_rss_kb / 1024 << "\n";
  for (const SessionSummary& ss : sessions) {
    s << "session." << ss.session << " log " << ss.log << " duration_s " << ss.duration_s
      << " frames " << ss.stereo_frames << " vo_ok " << ss.vo_ok << " keyframes " << ss.keyframes
      << " floor_events " << ss.floor_events << " nodes_added " << ss.nodes_added
      << " nodes_in_mapped_area " << ss.nodes_in_mapped_area << " relocalised_after_s "
      << ss.relocalised_after_s << " store_bytes " << ss.store_bytes << " store_edge_rows "
      << ss.store_edge_rows << "\n";
    for (const std::string& line : ss.self_calibration)
      s << "session." << ss.session << " self_calibration " << line << "\n";
  }
  for (const HourFigures& h : hours)
    s << "hour." << h.hour << " frames " << h.frames << " nodes_at_end " << h.nodes_at_end
      << " mapper_p99_ms " << h.mapper_p99_ms << " loopclose_p99_ms " << h.loopclose_p99_ms << "\n";
  s << "nodes " << nodes << "\nedges " << edges << "\nfloors " << floors << "\nloop_proposals "
    << loop_proposals << " (node " << mapper.requests_node << ", global " << mapper.requests_global
    << ")\nverified " << verified << "\naccepted_closures " << accepted_closures
    << " (in the final map's constraints: a folded pair counts as its first; "
    << mapper.loop_closures << " made over the run)\nrejected " << rejected << " (map gate "
    << mapper.rejected_map_gate << ", other floor " << mapper.rejected_floor << ", inconsistent "
    << mapper.rejected_inconsistent << ", recovered " << mapper.gate_recoveries
    << ", too far to recover " << mapper.recoveries_too_far << ")\nrelocalizations "
    << mapper.relocalizations << "\n";
  if (false_closures >= 0)
    s << "false_closures " << false_closures << " (of " << closures_with_truth << " with truth)\n";
  if (reach_fit) {
    // Node-mode requests by the true distance between the keyframes: registered / asked.
    constexpr double kEdges[] = {0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 1e9};
    s << "registration_reach node_requests " << reach.size()
      << " (same floor, with truth), registered by distance:";
    for (size_t b = 0; b + 1 < std::size(kEdges); ++b) {
      int asked = 0, ok = 0;
      for (const sim::ReachSample& r : reach)
        if (r.distance_m >= kEdges[b] && r.distance_m < kEdges[b + 1]) {
          ++asked;
          ok += r.ok ? 1 : 0;
        }
      s << " " << kEdges[b];
      if (b + 2 < std::size(kEdges))
        s << "-" << kEdges[b + 1];
      else
        s << "+";
      s << " m " << ok << "/" << asked;
    }
    s << "\nregistration_reach_fit success_probability " << reach_fit->success_probability
      << " distance_scale_m " << reach_fit->distance_scale_m << " angle_scale_rad "
      << reach_fit->angle_scale_rad << " (the oracle's p = P exp(-(d/D)^2/2) exp(-(a/A)^2/2) over "
      << reach_fit->samples << " requests; beyond its bounds " << reach_fit->beyond << ", "
      << reach_fit->ok_beyond << " registered; its defaults: 0.95, 2, 0.5)\n";
  }
  s << "vo " << vo.report();
  // Every counter of the mapper and of its tracker (mapper_stats.h, tracker_counts.h).
  const char* separator = "\nmapper ";
  for (const auto& c : mapper::MapperStats::counters())
    s << std::exchange(separator, ", ") << c.name << " " << mapper.*c.field;
  separator = "\ntracker ";
  for (const auto& c : mapper::TrackerCounts::counters())
    s << std::exchange(separator, ", ") << c.name << " " << tracker.*c.field;
  s << "\nloopclose " << loopclose.text() << "\n";
  if (evaluation) s << evaluation->text();
  const double n = std::max<double>(1.0, static_cast<double>(vo.frames));
  s << "ms_per_frame decode " << 1e3 * times.decode_s / n << " (reader thread) wait "
    << 1e3 * times.wait_s / n << " vo " << 1e3 * times.vo_s / n << " imu " << 1e3 * times.imu_s / n
    << " loopclose " << 1e3 * times.loopclose_s / n << " mapper " << 1e3 * times.mapper_s / n
    << "\ninput_errors " << input_errors << "\nframes_dropped " << frames_dropped << "\n";
  if (frames_named > 0) {
    s << "frames_named_dropped " << frames_named_dropped << " (of " << frames_named << " named)\n";
  }
  for (const std::string& e : errors) s << "error " << e << "\n";
  return s.str();
}

}  // namespace evermap::slam_run
