#include "tools/eval/map_figure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

namespace evermap::eval {
namespace {

using Eigen::Vector2d;

constexpr Rgb kLoopColor{214, 39, 40};
constexpr Rgb kPlateFill{246, 246, 242};
constexpr Rgb kPlateEdge{150, 150, 150};
constexpr Rgb kReferenceColor{190, 190, 190};
constexpr Rgb kTextColor{30, 30, 30};

// Session colours: a qualitative palette without red (red marks loop closures).
constexpr std::array<Rgb, 10> kSessionColors{{{31, 119, 180},
                                              {255, 127, 14},
                                              {44, 160, 44},
                                              {148, 103, 189},
                                              {140, 86, 75},
                                              {227, 119, 194},
                                              {127, 127, 127},
                                              {188, 189, 34},
                                              {23, 190, 207},
                                              {57, 59, 121}}};

Rgb sessionColor(int session) {
  const size_t n = kSessionColors.size();
  return kSessionColors[static_cast<size_t>(((session % static_cast<int>(n)) + n) % n)];
}

// Floor heights (mean node height per floor index) and the piecewise-linear map from a height
// to a drawing level (floor rank): a trajectory between floors is drawn between their plates.
struct FloorLevels {
  std::vector<int> floors;        // sorted by height
  std::vector<double> height_m;   // mean node height of each
  std::map<int, size_t> rank_of;  // floor index -> rank

  double levelOfHeight(double z) const {
    if (height_m.size() < 2) return 0.0;
    if (z <= height_m.front()) return 0.0;
    if (z >= height_m.back()) return static_cast<double>(height_m.size() - 1);
    const auto it = std::upper_bound(height_m.begin(), height_m.end(), z);
    const size_t k = static_cast<size_t>(it - height_m.begin());
    const double t = (z - height_m[k - 1]) / std::max(1e-9, height_m[k] - height_m[k - 1]);
    return static_cast<double>(k - 1) + t;
  }
};

FloorLevels floorLevels(const std::vector<MapFigureNode>& nodes) {
  std::map<int, std::pair<double, size_t>> sums;
  for (const MapFigureNode& n : nodes) {
    auto& [sum, count] = sums[n.floor];
    sum += n.p_world.z();
    ++count;
  }
  std::vector<std::pair<double, int>> order;
  for (const auto& [floor, sc] : sums) order.emplace_back(sc.first / sc.second, floor);
  std::sort(order.begin(), order.end());
  FloorLevels levels;
  for (const auto& [h, floor] : order) {
    levels.rank_of[floor] = levels.floors.size();
    levels.floors.push_back(floor);
    levels.height_m.push_back(h);
  }
  return levels;
}

// The oblique projection, before fitting to the canvas: (x, y, level) -> (right, up), metres.
struct Projection {
  double c = 1.0, s = 0.0, flatten = 0.45, level_m = 10.0;
  Vector2d operator()(double x, double y, double level) const {
    const double u = c * x - s * y;
    const double w = s * x + c * y;
    return {u, flatten * w + level * level_m};
  }
};

// Margins of the plot area, pixels: floor labels right of the plates, title above, legend below.
constexpr double kLabelPx = 190.0, kTopPx = 70.0, kBottomPx = 50.0, kLeftPx = 30.0;

Status checkFigure(const MapFigure& figure) {
  if (figure.nodes.empty()) return makeError("map figure: the map has no nodes");
  for (size_t i = 0; i < figure.nodes.size(); ++i) {
    if (!figure.nodes[i].p_world.allFinite()) {
      return makeError("map figure: node ", i, " has a non-finite position");
    }
  }
  for (const MapFigureEdge& e : figure.edges) {
    if (e.a >= figure.nodes.size() || e.b >= figure.nodes.size()) {
      return makeError("map figure: edge (", e.a, ", ", e.b, ") refers to a missing node");
    }
  }
  for (const core::Vec3& p : figure.reference) {
    if (!p.allFinite()) return makeError("map figure: the reference has a non-finite position");
  }
  return Ok{};
}

// The projection of the options; the horizontal extent sets the floor spacing, so the figure
// keeps its shape at any scale. `margin_m`: the plates' margin around their nodes.
Projection projectionOf(const MapFigure& figure, const MapFigureOptions& options,
                        double* margin_m) {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  auto grow = [&](const core::Vec3& p) {
    x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x());
    y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
  };
  for (const MapFigureNode& n : figure.nodes) grow(n.p_world);
  for (const core::Vec3& p : figure.reference) grow(p);
  const double extent = std::max({x1 - x0, y1 - y0, 1.0});
  *margin_m = 0.03 * extent;
  Projection proj;
  const double az = options.azimuth_deg * M_PI / 180.0;
  proj.c = std::cos(az);
  proj.s = std::sin(az);
  proj.flatten = options.flatten;
  proj.level_m = options.floor_spacing * extent;
  return proj;
}

// Per floor: the plate, the horizontal bounding box of its nodes with a margin.
std::vector<std::array<Vector2d, 4>> platesOf(const MapFigure& figure, const FloorLevels& levels,
                                              const Projection& proj, double margin_m) {
  std::vector<std::array<Vector2d, 4>> plates(levels.floors.size());
  std::vector<std::array<double, 4>> boxes(
      levels.floors.size(),
      {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
       -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()});
  for (const MapFigureNode& n : figure.nodes) {
    auto& b = boxes[levels.rank_of.at(n.floor)];
    b = {std::min(b[0], n.p_world.x()), std::min(b[1], n.p_world.y()),
         std::max(b[2], n.p_world.x()), std::max(b[3], n.p_world.y())};
  }
  for (size_t r = 0; r < plates.size(); ++r) {
    const auto& b = boxes[r];
    const double lv = static_cast<double>(r);
    plates[r] = {
        proj(b[0] - margin_m, b[1] - margin_m, lv), proj(b[2] + margin_m, b[1] - margin_m, lv),
        proj(b[2] + margin_m, b[3] + margin_m, lv), proj(b[0] - margin_m, b[3] + margin_m, lv)};
  }
  return plates;
}

// Where everything goes: plates, nodes and reference projected, fitted into the plot area at
// one scale.
struct Layout {
  std::vector<std::array<Vector2d, 4>> plates;  // by floor rank
  std::vector<Vector2d> node_uv, ref_uv;
  std::vector<double> node_level, ref_level;  // drawing level (floor rank)
  Vector2d lo;
  double ppm = 1.0, plot_h = 0.0;

  Vector2d px(const Vector2d& q) const {
    return Vector2d(kLeftPx + (q.x() - lo.x()) * ppm, kTopPx + plot_h - (q.y() - lo.y()) * ppm);
  }
};

Layout layoutOf(const MapFigure& figure, const FloorLevels& levels,
                const MapFigureOptions& options) {
  double margin_m = 0.0;
  const Projection proj = projectionOf(figure, options, &margin_m);
  Layout l;
  l.plates = platesOf(figure, levels, proj, margin_m);
  for (const MapFigureNode& n : figure.nodes) {
    l.node_level.push_back(static_cast<double>(levels.rank_of.at(n.floor)));
    l.node_uv.push_back(proj(n.p_world.x(), n.p_world.y(), l.node_level.back()));
  }
  for (const core::Vec3& p : figure.reference) {
    l.ref_level.push_back(levels.levelOfHeight(p.z()));
    l.ref_uv.push_back(proj(p.x(), p.y(), l.ref_level.back()));
  }
  Vector2d lo = Vector2d::Constant(std::numeric_limits<double>::infinity());
  Vector2d hi = -lo;
  auto fit = [&](const Vector2d& q) { lo = lo.cwiseMin(q), hi = hi.cwiseMax(q); };
  for (const auto& plate : l.plates) {
    for (const Vector2d& q : plate) fit(q);
  }
  for (const Vector2d& q : l.ref_uv) fit(q);
  const double plot_w = options.width_px - kLeftPx - kLabelPx;
  l.plot_h = options.height_px - kTopPx - kBottomPx;
  l.ppm = std::min(plot_w / std::max(1e-9, hi.x() - lo.x()),
                   l.plot_h / std::max(1e-9, hi.y() - lo.y()));
  l.lo = lo;
  return l;
}

// Floor rank `r`: its plate and label, the reference where it lies on or climbs from the
// floor, the edges drawn with the upper of their floors (loop closures over odometry), the
// nodes. `sessions` collects the sessions drawn.
void drawFloor(Canvas& canvas, const MapFigure& figure, const FloorLevels& levels, const Layout& l,
               size_t r, std::set<int>* sessions) {
  std::vector<Vector2d> plate_px;
  for (const Vector2d& q : l.plates[r]) plate_px.push_back(l.px(q));
  canvas.polygon(plate_px, kPlateEdge, 1.0, kPlateFill);
  const Vector2d right =
      *std::max_element(plate_px.begin(), plate_px.end(),
                        [](const Vector2d& a, const Vector2d& b) { return a.x() < b.x(); });
  char label[96];
  std::snprintf(label, sizeof label, "floor %d  (%.1f m)", levels.floors[r],
                std::abs(levels.height_m[r]) < 0.05 ? 0.0 : levels.height_m[r]);
  canvas.text(right + Vector2d(10, 4), label, 11, kTextColor);

  const double lv = static_cast<double>(r);
  std::vector<Vector2d> run;
  auto flush = [&] {
    if (run.size() >= 2) canvas.polyline(run, kReferenceColor, 1.0);
    run.clear();
  };
  for (size_t i = 0; i < l.ref_uv.size(); ++i) {
    if (l.ref_level[i] >= lv - 0.5 && l.ref_level[i] < lv + 0.5) {
      run.push_back(l.px(l.ref_uv[i]));
    } else {
      flush();
    }
  }
  flush();

  for (int pass = 0; pass < 2; ++pass) {
    for (const MapFigureEdge& e : figure.edges) {
      if (e.loop_closure != (pass == 1)) continue;
      if (std::max(l.node_level[e.a], l.node_level[e.b]) != lv) continue;
      const Rgb color = e.loop_closure ? kLoopColor : sessionColor(figure.nodes[e.b].session);
      canvas.line(l.px(l.node_uv[e.a]), l.px(l.node_uv[e.b]), color, e.loop_closure ? 0.8 : 1.0);
    }
  }
  for (size_t i = 0; i < figure.nodes.size(); ++i) {
    if (l.node_level[i] != lv) continue;
    sessions->insert(figure.nodes[i].session);
    canvas.circle(l.px(l.node_uv[i]), 1.6, sessionColor(figure.nodes[i].session), true);
  }
}

// Legend along the bottom: sessions, loop closures, reference.
void drawLegend(Canvas& canvas, const MapFigureOptions& options, const std::set<int>& sessions,
                bool reference) {
  double x = kLeftPx;
  const double y = options.height_px - 18.0;
  for (int s : sessions) {
    if (x > options.width_px - 160) break;
    canvas.circle({x + 5, y - 4}, 4, sessionColor(s), true);
    const std::string t = "session " + std::to_string(s);
    canvas.text({x + 14, y}, t, 10, kTextColor);
    x += 24 + Canvas::textWidthPx(t, 10);
  }
  canvas.line({x, y - 4}, {x + 18, y - 4}, kLoopColor, 1.5);
  canvas.text({x + 24, y}, "loop closure", 10, kTextColor);
  x += 34 + Canvas::textWidthPx("loop closure", 10);
  if (reference) {
    canvas.line({x, y - 4}, {x + 18, y - 4}, kReferenceColor, 1.5);
    canvas.text({x + 24, y}, "ground truth", 10, kTextColor);
  }
}

}  // namespace

Status MapFigureOptions::validate() const {
  if (!std::isfinite(azimuth_deg)) return makeError("map figure: azimuth must be finite");
  if (!(flatten > 0.0 && flatten <= 1.0)) return makeError("map figure: flatten must be in (0, 1]");
  if (!(floor_spacing >= 0.0 && floor_spacing <= 5.0)) {
    return makeError("map figure: floor_spacing must be in [0, 5]");
  }
  if (width_px < 300 || height_px < 250 || width_px > 8000 || height_px > 8000) {
    return makeError("map figure: size ", width_px, "x", height_px,
                     " out of range (300x250 to 8000x8000)");
  }
  return Ok{};
}

Expected<Canvas> drawMapFigure(const MapFigure& figure, const MapFigureOptions& options,
                               MapFigureSummary* summary) {
  if (Status s = options.validate(); !s) return s.error();
  if (Status s = checkFigure(figure); !s) return s.error();
  const FloorLevels levels = floorLevels(figure.nodes);
  const Layout layout = layoutOf(figure, levels, options);

  Canvas canvas(options.width_px, options.height_px);
  canvas.text({kLeftPx, 28}, options.title, 15, kTextColor);
  canvas.text({kLeftPx, 52}, options.subtitle, 12, kTextColor);
  // Bottom floor first, so that each plate hides what lies under it.
  std::set<int> sessions;
  for (size_t r = 0; r < layout.plates.size(); ++r)
    drawFloor(canvas, figure, levels, layout, r, &sessions);
  drawLegend(canvas, options, sessions, !figure.reference.empty());

  if (summary) {
    size_t loops = 0;
    for (const MapFigureEdge& e : figure.edges) loops += e.loop_closure ? 1 : 0;
    summary->floors = levels.floors.size();
    summary->sessions = sessions.size();
    summary->loop_closures = loops;
  }
  return canvas;
}

}  // namespace evermap::eval
