#include "tools/map-export/truth_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include "tools/eval/canvas.h"
#include "tools/sim/render_world.h"
#include "tools/sim/run.h"

namespace evermap::map_export {

namespace {

using core::Vec2;

// Labels as the renderer rasterises them (render_world.cpp): cell centres inside a region's
// boxes, later regions over earlier ones.
BuildingTruth::TrueFloor trueFloor(const sim::FloorSpec& spec, double cell) {
  BuildingTruth::TrueFloor f;
  Vec2 lo(1e18, 1e18), hi(-1e18, -1e18);
  for (const sim::Region& r : spec.regions)
    for (const sim::Box& b : r.boxes) {
      lo = lo.cwiseMin(b.min);
      hi = hi.cwiseMax(b.max);
    }
  f.cell = cell;
  f.x0 = (std::floor(lo.x() / cell) - 2.0) * cell;
  f.y0 = (std::floor(lo.y() / cell) - 2.0) * cell;
  f.w = static_cast<int>(std::ceil((hi.x() - f.x0) / cell)) + 2;
  f.h = static_cast<int>(std::ceil((hi.y() - f.y0) / cell)) + 2;
  std::vector<uint8_t> label(static_cast<size_t>(f.w) * f.h, 0);
  auto centre = [&](int i, int j) {
    return Vec2(f.x0 + (i + 0.5) * cell, f.y0 + (j + 0.5) * cell);
  };
  for (size_t r = 0; r < spec.regions.size(); ++r)
    for (const sim::Box& b : spec.regions[r].boxes)
      for (int j = 0; j < f.h; ++j)
        for (int i = 0; i < f.w; ++i)
          if (b.contains(centre(i, j))) label[static_cast<size_t>(j) * f.w + i] = r + 1;
  f.inside.resize(label.size());
  for (size_t k = 0; k < label.size(); ++k) f.inside[k] = label[k] != 0;
  auto isWall = [&](int la, int lb, const Vec2& mid) {
    if (la == lb) return false;
    for (const sim::Opening& op : spec.openings) {
      const bool pair = (op.a + 1 == la && op.b + 1 == lb) || (op.a + 1 == lb && op.b + 1 == la);
      if (pair && op.span.contains(mid)) return false;
    }
    return true;
  };
  for (int j = 0; j + 1 < f.h; ++j) {
    for (int i = 0; i + 1 < f.w; ++i) {
      const int l = label[static_cast<size_t>(j) * f.w + i];
      const int right = label[static_cast<size_t>(j) * f.w + i + 1];
      const int up = label[static_cast<size_t>(j + 1) * f.w + i];
      const double x = f.x0 + (i + 1) * cell, y = f.y0 + (j + 1) * cell;
      if (isWall(l, right, Vec2(x, y - 0.5 * cell))) {
        f.walls.push_back({Vec2(x, y - cell), Vec2(x, y)});
        f.samples.push_back(Vec2(x, y - 0.5 * cell));
      }
      if (isWall(l, up, Vec2(x - 0.5 * cell, y))) {
        f.walls.push_back({Vec2(x - cell, y), Vec2(x, y)});
        f.samples.push_back(Vec2(x - 0.5 * cell, y));
      }
    }
  }
  return f;
}

// Points bucketed for "any within r" queries.
class PointIndex {
 public:
  PointIndex(const std::vector<Vec2>& points, double bucket) : bucket_(bucket) {
    for (const Vec2& p : points) cells_[key(p)].push_back(p);
  }
  bool anyWithin(const Vec2& q, double r) const {
    const int64_t ci = std::floor(q.x() / bucket_), cj = std::floor(q.y() / bucket_);
    const int span = static_cast<int>(std::ceil(r / bucket_));
    for (int64_t dj = -span; dj <= span; ++dj)
      for (int64_t di = -span; di <= span; ++di) {
        const auto it = cells_.find(pack(ci + di, cj + dj));
        if (it == cells_.end()) continue;
        for (const Vec2& p : it->second)
          if ((p - q).squaredNorm() <= r * r) return true;
      }
    return false;
  }

 private:
  static int64_t pack(int64_t i, int64_t j) { return (i << 32) ^ (j & 0xffffffff); }
  int64_t key(const Vec2& p) const {
    return pack(static_cast<int64_t>(std::floor(p.x() / bucket_)),
                static_cast<int64_t>(std::floor(p.y() / bucket_)));
  }
  double bucket_;
  std::unordered_map<int64_t, std::vector<Vec2>> cells_;
};

Vec2 apply(const core::SE3d& T, const Vec2& p) {
  return (T * core::Vec3(p.x(), p.y(), 0.0)).head<2>();
}

// Whether any cell of `wanted` kind has its centre within r of p (map frame).
bool cellWithin(const OccupancyGrid& g, const Vec2& p, double r, Cell wanted) {
  const int span = static_cast<int>(std::ceil(r / g.resolution()));
  int ci = 0, cj = 0;
  const double fi = std::floor((p.x() - g.x0()) / g.resolution());
  const double fj = std::floor((p.y() - g.y0()) / g.resolution());
  ci = static_cast<int>(fi);
  cj = static_cast<int>(fj);
  for (int j = std::max(0, cj - span); j <= std::min(g.height() - 1, cj + span); ++j)
    for (int i = std::max(0, ci - span); i <= std::min(g.width() - 1, ci + span); ++i)
      if (g.cell(i, j) == wanted && (g.centre(i, j) - p).squaredNorm() <= r * r) return true;
  return false;
}

// The columns of slam-run's nodes.csv this needs, by name.
Expected<std::vector<std::vector<double>>> readColumns(const std::filesystem::path& file,
                                                       const std::vector<std::string>& names) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot read (--truth-nodes)");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) header.push_back(line);
  std::vector<size_t> at;
  for (const std::string& n : names) {
    const auto it = std::find(header.begin(), header.end(), n);
    if (it == header.end()) return makeError(file.string(), ": no column ", n);
    at.push_back(static_cast<size_t>(it - header.begin()));
  }
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    for (std::stringstream ss(line); std::getline(ss, line, ',');) f.push_back(line);
    std::vector<double> row;
    for (size_t k : at) {
      if (k >= f.size()) return makeError(file.string(), ": a short row");
      row.push_back(std::strtod(f[k].c_str(), nullptr));
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace

bool BuildingTruth::TrueFloor::isInside(const Vec2& p) const {
  const int i = static_cast<int>(std::floor((p.x() - x0) / cell));
  const int j = static_cast<int>(std::floor((p.y() - y0) / cell));
  return i >= 0 && j >= 0 && i < w && j < h && inside[static_cast<size_t>(j) * w + i] != 0;
}

Expected<BuildingTruth> BuildingTruth::load(const sim::ImageSimOptions& options,
                                            const std::filesystem::path& nodes_csv) {
  auto plan = sim::RunPlan::create(options.sim);
  if (!plan) return plan.error();
  BuildingTruth t;
  for (size_t f = 0; f < plan->building().floors.size(); ++f) {
    const sim::FloorSpec spec = sim::floorSpecOf(plan->building(), static_cast<int>(f),
                                                 options.sim.building, options.render.world);
    t.floors_.push_back(trueFloor(spec, options.render.world.grid_cell_m));
  }
  auto rows = readColumns(nodes_csv, {"node", "true_floor", "x", "y", "true_x", "true_y"});
  if (!rows) return rows.error();
  for (const auto& r : *rows)
    t.nodes_.push_back(
        {static_cast<int64_t>(r[0]), static_cast<int>(r[1]), Vec2(r[2], r[3]), Vec2(r[4], r[5])});
  return t;
}

namespace {

// The 2-D rigid fit truth ≈ R est + t (Kabsch in the plane), as an SE3d about z.
core::SE3d fitPlanar(const std::vector<Vec2>& est, const std::vector<Vec2>& truth, double* rmse) {
  Vec2 me = Vec2::Zero(), mt = Vec2::Zero();
  for (size_t k = 0; k < est.size(); ++k) {
    me += est[k];
    mt += truth[k];
  }
  me /= est.size();
  mt /= est.size();
  double s = 0.0, c = 0.0;
  for (size_t k = 0; k < est.size(); ++k) {
    const Vec2 a = est[k] - me, b = truth[k] - mt;
    c += a.dot(b);
    s += a.x() * b.y() - a.y() * b.x();
  }
  const double yaw = std::atan2(s, c);
  const Eigen::Rotation2Dd R(yaw);
  const Vec2 t = mt - R * me;
  double sum = 0.0;
  for (size_t k = 0; k < est.size(); ++k) sum += (R * est[k] + t - truth[k]).squaredNorm();
  *rmse = std::sqrt(sum / est.size());
  return core::SE3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, core::Vec3::UnitZ())),
                    core::Vec3(t.x(), t.y(), 0.0));
}

// The building floor most of a map floor's nodes are on.
int trueFloorOf(int floor, const ScanSet& scans, const std::map<int64_t, int>& true_floor) {
  std::map<int, int> votes;
  for (const NodeScan& n : scans.nodes)
    if (n.floor == floor)
      if (const auto it = true_floor.find(n.node); it != true_floor.end()) ++votes[it->second];
  int best = -1, most = 0;
  for (const auto& [f, v] : votes)
    if (v > most) best = f, most = v;
  return best;
}

}  // namespace

Expected<TruthComparison> BuildingTruth::compare(const std::vector<FloorPlan>& plans,
                                                 const ScanSet& scans, double tolerance_m) const {
  std::map<int64_t, const NodeTruth*> by_id;
  std::map<int64_t, int> true_floor;
  for (const NodeTruth& n : nodes_) {
    by_id[n.node] = &n;
    true_floor[n.node] = n.true_floor;
  }
  std::vector<Vec2> est, truth;
  for (const NodeScan& n : scans.nodes)
    if (const auto it = by_id.find(n.node); it != by_id.end()) {
      est.push_back(n.world_T_body.translation().head<2>());
      truth.push_back(it->second->truth);
    }
  if (est.size() < 3)
    return makeError("--truth-nodes: ", est.size(), " of the map's nodes have truth");
  TruthComparison c;
  c.truth_T_map = fitPlanar(est, truth, &c.fit_rmse_m);
  const core::SE3d map_T_truth = c.truth_T_map.inverse();
  for (const FloorPlan& p : plans) {
    FloorScore s;
    s.floor = p.floor;
    s.true_floor = trueFloorOf(p.floor, scans, true_floor);
    if (s.true_floor < 0 || s.true_floor >= static_cast<int>(floors_.size())) continue;
    const TrueFloor& tf = floors_[s.true_floor];
    const PointIndex walls(tf.samples, 0.25);
    const OccupancyGrid& g = p.grid;
    for (int j = 0; j < g.height(); ++j)
      for (int i = 0; i < g.width(); ++i) {
        const Cell cell = g.cell(i, j);
        if (cell == Cell::kUnknown) continue;
        const Vec2 q = apply(c.truth_T_map, g.centre(i, j));
        if (cell == Cell::kOccupied) {
          ++s.occupied;
          if (walls.anyWithin(q, tolerance_m)) ++s.occupied_near_wall;
        }
        const bool est_free = cell == Cell::kFree, true_free = tf.isInside(q);
        s.free_intersection += est_free && true_free;
        s.free_union += est_free || true_free;
      }
    for (const Vec2& w : tf.samples) {
      const Vec2 q = apply(map_T_truth, w);
      if (!cellWithin(g, q, 0.5, Cell::kFree)) continue;
      ++s.wall_samples;
      if (cellWithin(g, q, tolerance_m, Cell::kOccupied)) ++s.wall_samples_found;
    }
    c.floors.push_back(s);
  }
  return c;
}

std::string TruthComparison::text() const {
  std::ostringstream out;
  char buf[256];
  std::snprintf(buf, sizeof buf, "truth fit: yaw %.2f deg, rmse %.3f m (nodes, plane)\n",
                truth_T_map.so3().log().z() * 180.0 / M_PI, fit_rmse_m);
  out << buf;
  for (const FloorScore& s : floors) {
    std::snprintf(buf, sizeof buf,
                  "floor %d (building floor %d): occupied precision %.3f (%lld of %lld), wall "
                  "recall %.3f (%lld of %lld samples), free IoU %.3f\n",
                  s.floor, s.true_floor, s.precision(), (long long)s.occupied_near_wall,
                  (long long)s.occupied, s.recall(), (long long)s.wall_samples_found,
                  (long long)s.wall_samples, s.freeIou());
    out << buf;
  }
  return out.str();
}

Status BuildingTruth::drawFloor(const FloorPlan& plan, const TruthComparison& c,
                                const std::filesystem::path& file) const {
  const OccupancyGrid& g = plan.grid;
  const FloorScore* score = nullptr;
  for (const FloorScore& s : c.floors)
    if (s.floor == plan.floor) score = &s;
  const double px_per_cell = std::max(1.0, std::min(4.0, 1600.0 / std::max(1, g.width())));
  const int top = 60;
  const int W = std::max(16, static_cast<int>(g.width() * px_per_cell));
  const int H = std::max(16, static_cast<int>(g.height() * px_per_cell) + top);
  eval::Canvas canvas(W, H, {205, 205, 205});
  auto px = [&](const Vec2& p) {  // map frame -> pixels (y up)
    return Eigen::Vector2d((p.x() - g.x0()) / g.resolution() * px_per_cell,
                           top + (g.height() - (p.y() - g.y0()) / g.resolution()) * px_per_cell);
  };
  for (const Cell kind : {Cell::kFree, Cell::kOccupied}) {
    const eval::Rgb colour = kind == Cell::kFree ? eval::Rgb{255, 255, 255} : eval::Rgb{0, 0, 0};
    for (int j = 0; j < g.height(); ++j)
      for (int i = 0; i < g.width();) {
        if (g.cell(i, j) != kind) {
          ++i;
          continue;
        }
        int e = i;
        while (e < g.width() && g.cell(e, j) == kind) ++e;
        const Eigen::Vector2d a =
            px(Vec2(g.x0() + i * g.resolution(), g.y0() + (j + 1) * g.resolution()));
        canvas.rect(a, Eigen::Vector2d((e - i) * px_per_cell, px_per_cell), colour, 0, true,
                    colour);
        i = e;
      }
  }
  if (score) {
    const core::SE3d map_T_truth = c.truth_T_map.inverse();
    for (const Wall& w : floors_[score->true_floor].walls)
      canvas.line(px(apply(map_T_truth, w.a)), px(apply(map_T_truth, w.b)), {220, 30, 30}, 1.0);
  }
  char title[300];
  std::snprintf(title, sizeof title,
                "floor %d plan (black occupied, white free, grey unknown), %.2f m cells; red: the "
                "simulator's walls",
                plan.floor, g.resolution());
  canvas.text({10, 22}, title, 13, {0, 0, 0});
  if (score) {
    std::snprintf(title, sizeof title,
                  "occupied within 10 cm of a wall: precision %.2f, recall %.2f; free IoU %.2f",
                  score->precision(), score->recall(), score->freeIou());
    canvas.text({10, 46}, title, 13, {0, 0, 0});
  }
  return canvas.save(file);
}

}  // namespace evermap::map_export
