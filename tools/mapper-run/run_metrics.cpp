#include "tools/mapper-run/run_metrics.h"

#include "core/common/atomic_write.h"
#include "core/geometry/se2.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

namespace evermap::mapper {

Status writeTimelineCsv(const std::filesystem::path& file, const std::vector<TimelineRow>& rows) {
  std::ostringstream s;
  s << "operating_h,utime,session,nodes,factors,steps,tracking_s,registration_s,partition_s,solver_"
       "s,"
       "step_median_ms,step_p99_ms,step_max_ms,store_rows,store_bytes,views\n";
  for (const TimelineRow& r : rows)
    s << r.operating_s / 3600.0 << ',' << r.utime << ',' << r.session << ',' << r.nodes << ','
      << r.factors << ',' << r.steps << ',' << r.tracking_s << ',' << r.registration_s << ','
      << r.partition_s << ',' << r.solver_s << ',' << r.step_median_ms << ',' << r.step_p99_ms
      << ',' << r.step_max_ms << ',' << r.store_rows << ',' << r.store_bytes << ',' << r.views
      << '\n';
  const std::filesystem::path tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << s.str();
    if (!out.flush()) return makeError(file.string(), ": cannot write the timeline");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) return makeError(file.string(), ": ", ec.message());
  return Ok{};
}

Status writeErrorsCsv(const std::filesystem::path& steps_file,
                      const std::filesystem::path& nodes_file, const OfflineRunSummary& summary) {
  std::ostringstream steps;
  steps << "utime,session,node,true_floor,error_m,true_x,true_y,true_z,est_x,est_y,est_z,yaw_error_"
           "deg\n";
  steps.precision(10);
  for (size_t k = 0; k < summary.step_errors.size(); ++k) {
    const auto& e = summary.step_errors[k];
    const core::Vec3& t = summary.trajectory_gt[k];
    const core::Vec3& x = summary.trajectory_est[k];
    steps << e.utime << ',' << e.session << ',' << e.node << ',' << e.true_floor << ',' << e.error_m
          << ',' << t.x() << ',' << t.y() << ',' << t.z() << ',' << x.x() << ',' << x.y() << ','
          << x.z() << ',' << e.yaw_error_deg << '\n';
  }
  if (Status s = writeFileAtomically(steps_file, steps.str()); !s) return s;
  std::ostringstream nodes;
  nodes << "node,session,floor,keyframe_utime,error_m,true_x,true_y,true_z,true_qw,true_qx,true_qy,"
           "true_qz\n";
  nodes.precision(10);
  for (const auto& e : summary.node_errors) {
    const core::Vec3& t = e.world_T_body_true.translation();
    const Eigen::Quaterniond& q = e.world_T_body_true.quaternion();
    nodes << e.id << ',' << e.session << ',' << e.floor << ',' << e.keyframe_utime << ','
          << e.error_m << ',' << t.x() << ',' << t.y() << ',' << t.z() << ',' << q.w() << ','
          << q.x() << ',' << q.y() << ',' << q.z() << '\n';
  }
  return writeFileAtomically(nodes_file, nodes.str());
}

Expected<std::vector<TimelineRow>> readTimelineCsv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  std::vector<TimelineRow> rows;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 1) continue;  // header
    TimelineRow r;
    double hours = 0.0;
    long long utime = 0, nodes = 0, factors = 0, steps = 0, store_rows = -1, store_bytes = -1,
              views = -1;
    int session = 0;
    // 16 columns; timelines written before the views were added have 15, before the store's 13.
    const int fields = std::sscanf(
        line.c_str(), "%lf,%lld,%d,%lld,%lld,%lld,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lld,%lld,%lld",
        &hours, &utime, &session, &nodes, &factors, &steps, &r.tracking_s, &r.registration_s,
        &r.partition_s, &r.solver_s, &r.step_median_ms, &r.step_p99_ms, &r.step_max_ms, &store_rows,
        &store_bytes, &views);
    if (fields != 13 && fields != 15 && fields != 16)
      return makeError(file.string(), ":", n, ": not a timeline row");
    r.store_rows = store_rows;
    r.store_bytes = store_bytes;
    r.views = views;
    r.operating_s = 3600.0 * hours;
    r.utime = utime;
    r.session = session;
    r.nodes = nodes;
    r.factors = factors;
    r.steps = steps;
    rows.push_back(r);
  }
  return rows;
}

std::vector<PlaceCause> placeCauses(const std::vector<NodeTruth>& nodes,
                                    const std::vector<NodeTruth>& queries, double radius_m,
                                    double angle_rad) {
  std::vector<PlaceCause> causes;
  causes.reserve(queries.size());
  FloorGrid<size_t> grid(radius_m);
  for (size_t i = 0; i < nodes.size(); ++i) {
    const core::Vec3& p = nodes[i].world_T_body.translation();
    if (nodes[i].known) grid.add(nodes[i].floor, p.x(), p.y(), i);
  }
  for (const NodeTruth& q : queries) {
    if (!q.known) {
      causes.push_back(PlaceCause::kUnknown);
      continue;
    }
    PlaceCause cause = PlaceCause::kNewPlace;
    const core::Vec3& p = q.world_T_body.translation();
    grid.any(q.floor, p.x(), p.y(), [&](size_t j) {
      const NodeTruth& m = nodes[j];
      if (m.session >= q.session) return false;
      const double d = (m.world_T_body.translation() - p).head<2>().norm();
      if (d > radius_m) return false;
      cause = PlaceCause::kNewHeading;
      if (PartitionIndex::headingApartRad(core::toPlanar(m.world_T_body),
                                          core::toPlanar(q.world_T_body)) > angle_rad)
        return false;
      cause = PlaceCause::kMapped;
      return true;
    });
    causes.push_back(cause);
  }
  return causes;
}

std::vector<int64_t> inMappedArea(const std::vector<NodeTruth>& nodes,
                                  const std::vector<NodeTruth>& queries, double radius_m,
                                  double angle_rad) {
  std::vector<int64_t> by_session;
  const std::vector<PlaceCause> causes = placeCauses(nodes, queries, radius_m, angle_rad);
  for (size_t k = 0; k < queries.size(); ++k) {
    const NodeTruth& q = queries[k];
    if (q.session >= static_cast<int>(by_session.size())) by_session.resize(q.session + 1, 0);
    if (causes[k] == PlaceCause::kMapped) ++by_session[q.session];
  }
  return by_session;
}

bool ViewCover::add(int floor, const core::SE3d& world_T_body) {
  const core::SE2d p = core::toPlanar(world_T_body);
  const bool seen = views_.any(floor, p.x(), p.y(), [&](const core::SE2d& v) {
    return std::hypot(v.x() - p.x(), v.y() - p.y()) <= radius_m_ &&
           PartitionIndex::headingApartRad(v, p) <= heading_rad_;
  });
  if (seen) return false;
  views_.add(floor, p.x(), p.y(), p);
  ++count_;
  return true;
}

}  // namespace evermap::mapper
