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

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  return v[k];
}

Status writeTimelineCsv(const std::filesystem::path& file, const std::vector<TimelineRow>& rows) {
  std::ostringstream s;
  s << "operating_h,utime,session,nodes,factors,steps,tracking_s,registration_s,partition_s,solver_s,"
       "step_median_ms,step_p99_ms,step_max_ms,store_rows,store_bytes,views\n";
  for (const TimelineRow& r : rows)
    s << r.operating_s / 3600.0 << ',' << r.utime << ',' << r.session << ',' << r.nodes << ',' << r.factors << ','
      << r.steps << ',' << r.tracking_s << ',' << r.registration_s << ',' << r.partition_s << ',' << r.solver_s
      << ',' << r.step_median_ms << ',' << r.step_p99_ms << ',' << r.step_max_ms << ',' << r.store_rows << ','
      << r.store_bytes << ',' << r.views << '\n';
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

Status writeErrorsCsv(const std::filesystem::path& steps_file, const std::filesystem::path& nodes_file,
                      const OfflineRunSummary& summary) {
  std::ostringstream steps;
  steps << "utime,session,node,true_floor,error_m,true_x,true_y,true_z,est_x,est_y,est_z,yaw_error_deg\n";
  steps.precision(10);
  for (size_t k = 0; k < summary.step_errors.size(); ++k) {
    const auto& e = summary.step_errors[k];
    const core::Vec3& t = summary.trajectory_gt[k];
    const core::Vec3& x = summary.trajectory_est[k];
    steps << e.utime << ',' << e.session << ',' << e.node << ',' << e.true_floor << ',' << e.error_m << ',' << t.x()
          << ',' << t.y() << ',' << t.z() << ',' << x.x() << ',' << x.y() << ',' << x.z() << ',' << e.yaw_error_deg << '\n';
  }
  if (Status s = writeFileAtomically(steps_file, steps.str()); !s) return s;
  std::ostringstream nodes;
  nodes << "node,session,floor,keyframe_utime,error_m,true_x,true_y,true_z,true_qw,true_qx,true_qy,true_qz\n";
  nodes.precision(10);
  for (const auto& e : summary.node_errors) {
    const core::Vec3& t = e.world_T_body_true.translation();
    const Eigen::Quaterniond& q = e.world_T_body_true.quaternion();
    nodes << e.id << ',' << e.session << ',' << e.floor << ',' << e.keyframe_utime << ',' << e.error_m << ',' << t.x()
          << ',' << t.y() << ',' << t.z() << ',' << q.w() << ',' << q.x() << ',' << q.y() << ',' << q.z() << '\n';
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
    long long utime = 0, nodes = 0, factors = 0, steps = 0, store_rows = -1, store_bytes = -1, views = -1;
    int session = 0;
    // 16 columns; timelines written before the views were added have 15, before the store's 13.
    const int fields = std::sscanf(line.c_str(), "%lf,%lld,%d,%lld,%lld,%lld,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lld,%lld,%lld", &hours,
                                   &utime, &session, &nodes, &factors, &steps, &r.tracking_s, &r.registration_s,
                                   &r.partition_s, &r.solver_s, &r.step_median_ms, &r.step_p99_ms, &r.step_max_ms,
                                   &store_rows, &store_bytes, &views);
    if (fields != 13 && fields != 15 && fields != 16) return makeError(file.string(), ":", n, ": not a timeline row");
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

std::vector<PlaceCause> placeCauses(const std::vector<NodeTruth>& nodes, const std::vector<NodeTruth>& queries,
                                    double radius_m, double angle_rad) {
  std::vector<PlaceCause> causes;
  causes.reserve(queries.size());
  // Nodes on a grid of radius-sized cells: neighbours lie in the 3x3 block around a cell.
  std::map<std::tuple<int, int64_t, int64_t>, std::vector<size_t>> grid;
  auto key = [&](const NodeTruth& n, int64_t dx, int64_t dy) {
    const core::Vec3& p = n.world_T_body.translation();
    return std::make_tuple(n.floor, static_cast<int64_t>(std::floor(p.x() / radius_m)) + dx,
                           static_cast<int64_t>(std::floor(p.y() / radius_m)) + dy);
  };
  for (size_t i = 0; i < nodes.size(); ++i)
    if (nodes[i].known) grid[key(nodes[i], 0, 0)].push_back(i);
  for (const NodeTruth& q : queries) {
    if (!q.known) {
      causes.push_back(PlaceCause::kUnknown);
      continue;
    }
    PlaceCause cause = PlaceCause::kNewPlace;
    for (int64_t dx = -1; dx <= 1 && cause != PlaceCause::kMapped; ++dx) {
      for (int64_t dy = -1; dy <= 1 && cause != PlaceCause::kMapped; ++dy) {
        auto it = grid.find(key(q, dx, dy));
        if (it == grid.end()) continue;
        for (size_t j : it->second) {
          const NodeTruth& m = nodes[j];
          if (m.session >= q.session) continue;
          const double d = (m.world_T_body.translation() - q.world_T_body.translation()).head<2>().norm();
          if (d > radius_m) continue;
          cause = PlaceCause::kNewHeading;
          const double a = std::abs(std::remainder(core::toPlanar(m.world_T_body).theta() - core::toPlanar(q.world_T_body).theta(), 2 * M_PI));
          if (a <= angle_rad) {
            cause = PlaceCause::kMapped;
            break;
          }
        }
      }
    }
    causes.push_back(cause);
  }
  return causes;
}

std::vector<int64_t> inMappedArea(const std::vector<NodeTruth>& nodes, const std::vector<NodeTruth>& queries,
                                  double radius_m, double angle_rad) {
  std::vector<int64_t> by_session;
  const std::vector<PlaceCause> causes = placeCauses(nodes, queries, radius_m, angle_rad);
  for (size_t k = 0; k < queries.size(); ++k) {
    const NodeTruth& q = queries[k];
    if (q.session >= static_cast<int>(by_session.size())) by_session.resize(q.session + 1, 0);
    if (causes[k] == PlaceCause::kMapped) ++by_session[q.session];
  }
  return by_session;
}

ViewCover::Key ViewCover::key(int floor, double x, double y) const {
  return {floor, static_cast<int64_t>(std::floor(x / radius_m_)), static_cast<int64_t>(std::floor(y / radius_m_))};
}

bool ViewCover::add(int floor, const core::SE3d& world_T_body) {
  const core::SE2d p = core::toPlanar(world_T_body);
  const auto [f, ix, iy] = key(floor, p.x(), p.y());
  for (int64_t dx = -1; dx <= 1; ++dx) {
    for (int64_t dy = -1; dy <= 1; ++dy) {
      auto it = grid_.find(Key{f, ix + dx, iy + dy});
      if (it == grid_.end()) continue;
      for (const core::SE2d& v : it->second) {
        if (std::hypot(v.x() - p.x(), v.y() - p.y()) > radius_m_) continue;
        if (std::abs(std::remainder(v.theta() - p.theta(), 2 * M_PI)) <= heading_rad_) return false;
      }
    }
  }
  grid_[Key{f, ix, iy}].push_back(p);
  ++views_;
  return true;
}

}  // namespace evermap::mapper
