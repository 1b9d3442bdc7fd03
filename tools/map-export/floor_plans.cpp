#include "tools/map-export/floor_plans.h"

#include <algorithm>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <string>

#include "core/common/atomic_write.h"

namespace evermap::map_export {

namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

void putPose(std::ostream& out, const core::SE3d& T) {
  const core::Vec3& t = T.translation();
  const auto& q = T.quaternion();
  out << "," << t.x() << "," << t.y() << "," << t.z() << "," << q.w() << "," << q.x() << ","
      << q.y() << "," << q.z();
}

std::string nodesCsv(const map::MapSnapshot& map) {
  std::ostringstream out;
  out << std::setprecision(9) << "node,session,floor,keyframe_utime,x,y,z,qw,qx,qy,qz\n";
  for (const map::StoredNode& n : map.nodes) {
    out << n.node.id << "," << n.node.session << "," << n.node.floor << ","
        << n.node.keyframe_utime;
    putPose(out, n.world_T_body);
    out << "\n";
  }
  return out.str();
}

std::string edgesCsv(const map::MapSnapshot& map) {
  std::map<int64_t, const map::MapperNode*> by_id;
  for (const map::StoredNode& n : map.nodes) by_id[n.node.id] = &n.node;
  auto field = [&](int64_t id, bool floor) -> std::string {
    const auto it = by_id.find(id);
    if (it == by_id.end()) return "";
    return std::to_string(floor ? it->second->floor : it->second->session);
  };
  std::ostringstream out;
  out << std::setprecision(9)
      << "edge,from,to,kind,accepted,from_floor,to_floor,from_session,to_session,"
         "x,y,z,qw,qx,qy,qz\n";
  for (const map::StoredEdge& e : map.edges) {
    const map::Constraint& c = e.constraint;
    out << e.edge_id << "," << c.from << "," << c.to << ","
        << (c.kind == map::ConstraintKind::kLoop ? "loop" : "odometry") << ","
        << (c.accepted ? 1 : 0) << "," << field(c.from, true) << "," << field(c.to, true) << ","
        << field(c.from, false) << "," << field(c.to, false);
    putPose(out, c.from_T_to.mean);
    out << "\n";
  }
  return out.str();
}

std::string pointsPly(const ScanSet& scans, double max_range_m, int64_t* count) {
  std::string body;
  *count = 0;
  for (const NodeScan& n : scans.nodes) {
    for (const core::Vec3& p : n.scan.points) {
      if (!((p - n.scan.camera).norm() <= max_range_m)) continue;
      const float xyz[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()),
                            static_cast<float>(p.z())};
      body.append(reinterpret_cast<const char*>(xyz), sizeof xyz);  // little-endian hosts
      ++*count;
    }
  }
  return "ply\nformat binary_little_endian 1.0\ncomment evermap-map-export: keyframe points, "
         "map frame, metres\nelement vertex " +
         std::to_string(*count) + "\nproperty float x\nproperty float y\nproperty float z\n" +
         "end_header\n" + body;
}

}  // namespace

std::vector<FloorPlan> makeFloorPlans(const ScanSet& scans, const GridOptions& o) {
  std::map<int, std::vector<const NodeScan*>> by_floor;
  for (const NodeScan& n : scans.nodes) by_floor[n.floor].push_back(&n);
  std::vector<FloorPlan> plans;
  for (const auto& [floor, nodes] : by_floor) {
    std::vector<double> z;
    std::vector<Scan> floor_scans;
    for (const NodeScan* n : nodes) {
      z.push_back(n->world_T_body.translation().z());
      floor_scans.push_back(n->scan);
    }
    FloorPlan plan{floor, median(z), static_cast<int64_t>(nodes.size()),
                   OccupancyGrid::covering(floor_scans, o)};
    for (const Scan& s : floor_scans) plan.grid.addScan(s, plan.floor_z, o);
    plans.push_back(std::move(plan));
  }
  return plans;
}

Expected<ExportSummary> writeExport(const std::filesystem::path& dir, const map::MapSnapshot& map,
                                    const ScanSet& scans, const std::vector<FloorPlan>& plans,
                                    double max_range_m) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return makeError(dir.string(), ": cannot create (", ec.message(), ")");
  ExportSummary summary;
  auto write = [&](const std::string& name, const std::string& bytes) -> Status {
    if (Status s = writeFileAtomically(dir / name, bytes); !s) return s;
    ++summary.files;
    summary.bytes += static_cast<int64_t>(bytes.size());
    return Ok{};
  };
  for (const FloorPlan& p : plans) {
    const std::string name = "floor-" + std::to_string(p.floor);
    if (Status s = write(name + ".pgm", p.grid.pgm()); !s) return s.error();
    if (Status s = write(name + ".yaml", p.grid.yaml(name + ".pgm")); !s) return s.error();
  }
  if (Status s = write("nodes.csv", nodesCsv(map)); !s) return s.error();
  if (Status s = write("edges.csv", edgesCsv(map)); !s) return s.error();
  if (Status s = write("points.ply", pointsPly(scans, max_range_m, &summary.points)); !s)
    return s.error();
  return summary;
}

}  // namespace evermap::map_export
