#include "tools/eval/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include "core/common/enum_names.h"

namespace evermap::eval {
namespace {

using Eigen::Vector2d;

constexpr Rgb kGtColor{0, 0, 0};
constexpr Rgb kEstColor{31, 119, 180};
constexpr Rgb kGridColor{225, 225, 225};
constexpr Rgb kFrameColor{90, 90, 90};
constexpr Rgb kTextColor{30, 30, 30};

// `x` rounded to the nearest "nice" number: 1, 2 or 5 times a power of ten.
double niceStep(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  const double m = x / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

std::string tickText(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < 0.5 * step * 1e-6 ? 0.0 : v);
  return buf;
}

// Maps plane coordinates (metres, second axis up) to pixels (y down).
struct View {
  double x0, y0, w, h;  // plot area, pixels
  double u_min, v_min;  // plane coordinates at the bottom-left corner
  double ppm;           // pixels per metre, equal on both axes

  Vector2d px(const Vector2d& uv) const {
    return {x0 + (uv.x() - u_min) * ppm, y0 + h - (uv.y() - v_min) * ppm};
  }
  double uMax() const { return u_min + w / ppm; }
  double vMax() const { return v_min + h / ppm; }
};

// Drops points closer than half a pixel to the last kept one: a 30 000-pose ground truth
// becomes a few thousand vertices without a visible change.
std::vector<Vector2d> toPixels(const View& view, const std::vector<Vector2d>& uv) {
  std::vector<Vector2d> out;
  for (const Vector2d& p : uv) {
    const Vector2d q = view.px(p);
    if (out.empty() || (q - out.back()).squaredNorm() >= 0.25) out.push_back(q);
  }
  if (!uv.empty() && out.size() == 1) out.push_back(out.front());
  return out;
}

// The two axes drawn: the options' plane, or (auto) the two of largest extent of the ground
// truth.
std::array<int, 2> plotAxes(const std::vector<core::Vec3>& gt, PlotPlane plane) {
  core::Vec3 lo = gt.front(), hi = gt.front();
  for (const core::Vec3& p : gt) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (plane == PlotPlane::kAuto) {
    Eigen::Index vertical = 0;
    (hi - lo).minCoeff(&vertical);
    plane = vertical == 2 ? PlotPlane::kXY : vertical == 1 ? PlotPlane::kXZ : PlotPlane::kYZ;
  }
  if (plane == PlotPlane::kXZ) return {0, 2};
  if (plane == PlotPlane::kYZ) return {1, 2};
  return {0, 1};
}

// Equal scale on both axes, the data centred in the plot area with a 6 % margin.
View viewOf(const std::vector<Vector2d>& gt_uv, const std::vector<Vector2d>& est_uv, double W,
            double H) {
  View view{72.0, 100.0, W - 72.0 - 24.0, H - 100.0 - 56.0, 0, 0, 1};
  Vector2d a = gt_uv.front(), b = gt_uv.front();
  for (const auto* list : {&gt_uv, &est_uv}) {
    for (const Vector2d& p : *list) {
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
  }
  const double span_floor = std::max(1e-3 * (b - a).maxCoeff(), 1e-6);
  const Vector2d span = (b - a).cwiseMax(Vector2d(span_floor, span_floor)) * 1.12;
  view.ppm = std::min(view.w / span.x(), view.h / span.y());
  const Vector2d centre = 0.5 * (a + b);
  view.u_min = centre.x() - 0.5 * view.w / view.ppm;
  view.v_min = centre.y() - 0.5 * view.h / view.ppm;
  return view;
}

// Grid and tick labels, one step for both axes so that squares stay squares; the frame, the
// axis names and the titles.
void drawFrame(Canvas& c, const View& view, const std::array<int, 2>& axes,
               const TopViewOptions& options) {
  const double W = options.width_px, H = options.height_px;
  const char* names = "xyz";
  const double step = niceStep(std::max(view.uMax() - view.u_min, view.vMax() - view.v_min) / 8.0);
  for (double u = std::ceil(view.u_min / step) * step; u <= view.uMax(); u += step) {
    const double x = view.px({u, 0}).x();
    c.line({x, view.y0}, {x, view.y0 + view.h}, kGridColor, 1);
    c.text({x, view.y0 + view.h + 18}, tickText(u, step), 10, kTextColor, TextAnchor::kMiddle);
  }
  for (double v = std::ceil(view.v_min / step) * step; v <= view.vMax(); v += step) {
    const double y = view.px({0, v}).y();
    c.line({view.x0, y}, {view.x0 + view.w, y}, kGridColor, 1);
    c.text({view.x0 - 6, y + 5}, tickText(v, step), 10, kTextColor, TextAnchor::kEnd);
  }
  c.rect({view.x0, view.y0}, {view.w, view.h}, kFrameColor, 1);
  c.text({view.x0 + 0.5 * view.w, H - 14}, std::string(1, names[axes[0]]) + " [m]", 12, kTextColor,
         TextAnchor::kMiddle);
  c.text({view.x0 - 6, view.y0 - 8}, std::string(1, names[axes[1]]) + " [m]", 12, kTextColor,
         TextAnchor::kEnd);
  if (!options.title.empty()) {
    c.text({0.5 * W, 26}, options.title, 14, kTextColor, TextAnchor::kMiddle);
  }
  if (!options.subtitle.empty()) {
    c.text({0.5 * W, 48}, options.subtitle, 11, kTextColor, TextAnchor::kMiddle);
  }
}

// Legend in a row between the titles and the plot, scale bar under the plot's right end:
// outside the plot area, they never hide a part of a trajectory.
void drawLegend(Canvas& c, const View& view, const TopViewOptions& options) {
  const double W = options.width_px, H = options.height_px;
  const std::array<std::string, 3> labels = {options.gt_label, options.est_label, "start"};
  double legend_w = 0;
  for (const auto& l : labels) legend_w += 34 + Canvas::textWidthPx(l, 11) + 24;
  double lx = std::max(view.x0, 0.5 * (W - legend_w + 24));
  const double ly = view.y0 - 22;
  for (int k = 0; k < 3; ++k) {
    if (k < 2) {
      c.line({lx, ly}, {lx + 28, ly}, k == 0 ? kGtColor : kEstColor, k == 0 ? 2.5 : 1.5);
    } else {
      c.circle({lx + 14, ly}, 5, kGtColor, true);
    }
    c.text({lx + 34, ly + 5}, labels[k], 11, kTextColor);
    lx += 34 + Canvas::textWidthPx(labels[k], 11) + 24;
  }
  const double bar_m = niceStep((view.uMax() - view.u_min) / 6.0);
  const double bar_px = bar_m * view.ppm;
  const double bar_right = view.x0 + view.w;
  const double bar_y = H - 19;
  c.line({bar_right - bar_px, bar_y}, {bar_right, bar_y}, kTextColor, 3);
  c.line({bar_right - bar_px, bar_y - 5}, {bar_right - bar_px, bar_y + 5}, kTextColor, 2);
  c.line({bar_right, bar_y - 5}, {bar_right, bar_y + 5}, kTextColor, 2);
  c.text({bar_right - bar_px - 8, bar_y + 5}, tickText(bar_m, bar_m) + " m", 11, kTextColor,
         TextAnchor::kEnd);
}

}  // namespace

namespace {
constexpr EnumNames<PlotPlane, 4> kPlotPlaneNames{{
    {PlotPlane::kAuto, "auto"},
    {PlotPlane::kXY, "xy"},
    {PlotPlane::kXZ, "xz"},
    {PlotPlane::kYZ, "yz"},
}};
}  // namespace

const char* toString(PlotPlane plane) { return nameOf(kPlotPlaneNames, plane); }

Expected<PlotPlane> parsePlotPlane(std::string_view name) {
  return parseName(kPlotPlaneNames, name, "plot plane");
}

Status TopViewOptions::validate() const {
  if (width_px < 300 || height_px < 250 || width_px > 8000 || height_px > 8000) {
    return makeError("plot size must be between 300x250 and 8000x8000 pixels, got ", width_px, "x",
                     height_px);
  }
  return Ok{};
}

Expected<Canvas> drawTopView(const std::vector<core::Vec3>& gt, const std::vector<core::Vec3>& est,
                             const TopViewOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (gt.empty() || est.empty()) return makeError("plot: nothing to draw (no poses)");
  for (const auto* list : {&gt, &est}) {
    for (const core::Vec3& p : *list) {
      if (!p.allFinite()) return makeError("plot: a position is not finite");
    }
  }
  const std::array<int, 2> axes = plotAxes(gt, options.plane);
  auto project = [&](const std::vector<core::Vec3>& pts) {
    std::vector<Vector2d> uv;
    uv.reserve(pts.size());
    for (const auto& p : pts) uv.emplace_back(p[axes[0]], p[axes[1]]);
    return uv;
  };
  const std::vector<Vector2d> gt_uv = project(gt);
  const std::vector<Vector2d> est_uv = project(est);
  const View view = viewOf(gt_uv, est_uv, options.width_px, options.height_px);

  Canvas c(options.width_px, options.height_px);
  drawFrame(c, view, axes, options);
  // The trajectories: ground truth wide and black underneath, the estimate thin on top, so
  // that both stay visible where they agree.
  const std::vector<Vector2d> gt_px = toPixels(view, gt_uv);
  const std::vector<Vector2d> est_px = toPixels(view, est_uv);
  c.polyline(gt_px, kGtColor, 2.5);
  c.polyline(est_px, kEstColor, 1.5);
  c.circle(gt_px.front(), 6, kGtColor, true);
  c.circle(est_px.front(), 6, kEstColor, false);
  drawLegend(c, view, options);
  return c;
}

Status writeTopView(const std::filesystem::path& file, const std::vector<core::Vec3>& gt,
                    const std::vector<core::Vec3>& est, const TopViewOptions& options) {
  auto canvas = drawTopView(gt, est, options);
  if (!canvas) return makeError(file.string(), ": ", canvas.error().message);
  return canvas->save(file);
}

Status LineChartOptions::validate() const {
  if (width_px < 200 || width_px > 16384 || height_px < 150 || height_px > 16384)
    return makeError("chart: image size ", width_px, "x", height_px,
                     " px is outside [200x150, 16384x16384]");
  return Ok{};
}

Expected<Canvas> drawLineChart(const std::vector<ChartSeries>& series,
                               const LineChartOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (series.empty()) return makeError("chart: nothing to draw (no series)");
  Vector2d lo(std::numeric_limits<double>::infinity(), 0.0);
  Vector2d hi(-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity());
  for (const ChartSeries& s : series) {
    if (s.points.empty()) return makeError("chart: series '", s.label, "' has no points");
    for (const Vector2d& p : s.points) {
      if (!p.allFinite()) return makeError("chart: series '", s.label, "' has a non-finite point");
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  if (!(hi.x() > lo.x())) hi.x() = lo.x() + 1.0;
  if (!(hi.y() > lo.y())) hi.y() = lo.y() + 1.0;
  hi.y() += 0.05 * (hi.y() - lo.y());
  const double W = options.width_px, H = options.height_px;
  const double x0 = 80, y0 = 100, w = W - x0 - 24, h = H - y0 - 56;
  auto px = [&](const Vector2d& p) {
    return Vector2d(x0 + (p.x() - lo.x()) / (hi.x() - lo.x()) * w,
                    y0 + h - (p.y() - lo.y()) / (hi.y() - lo.y()) * h);
  };
  Canvas c(options.width_px, options.height_px);
  const double xs = niceStep((hi.x() - lo.x()) / 8.0), ys = niceStep((hi.y() - lo.y()) / 6.0);
  for (double x = std::ceil(lo.x() / xs) * xs; x <= hi.x() + 1e-9 * xs; x += xs) {
    const double u = px({x, lo.y()}).x();
    c.line({u, y0}, {u, y0 + h}, kGridColor, 1);
    c.text({u, y0 + h + 18}, tickText(x, xs), 10, kTextColor, TextAnchor::kMiddle);
  }
  for (double y = std::ceil(lo.y() / ys) * ys; y <= hi.y() + 1e-9 * ys; y += ys) {
    const double v = px({lo.x(), y}).y();
    c.line({x0, v}, {x0 + w, v}, kGridColor, 1);
    c.text({x0 - 6, v + 5}, tickText(y, ys), 10, kTextColor, TextAnchor::kEnd);
  }
  c.rect({x0, y0}, {w, h}, kFrameColor, 1);
  c.text({x0 + 0.5 * w, H - 14}, options.x_label, 12, kTextColor, TextAnchor::kMiddle);
  c.text({x0 - 6, y0 - 8}, options.y_label, 12, kTextColor, TextAnchor::kStart);
  if (!options.title.empty())
    c.text({0.5 * W, 26}, options.title, 14, kTextColor, TextAnchor::kMiddle);
  if (!options.subtitle.empty())
    c.text({0.5 * W, 48}, options.subtitle, 11, kTextColor, TextAnchor::kMiddle);
  double lx = x0 + 160;
  const double ly = y0 - 22;
  for (const ChartSeries& s : series) {
    std::vector<Vector2d> pts;
    for (const Vector2d& p : s.points) {
      const Vector2d q = px(p);
      if (pts.empty() || (q - pts.back()).squaredNorm() >= 0.25) pts.push_back(q);
    }
    if (pts.size() == 1) pts.push_back(pts.front());
    c.polyline(pts, s.color, 1.8, s.dashed);
    c.line({lx, ly}, {lx + 28, ly}, s.color, 2.5);
    c.text({lx + 34, ly + 5}, s.label, 11, kTextColor);
    lx += 34 + Canvas::textWidthPx(s.label, 11) + 24;
  }
  return c;
}

Status writeLineChart(const std::filesystem::path& file, const std::vector<ChartSeries>& series,
                      const LineChartOptions& options) {
  auto canvas = drawLineChart(series, options);
  if (!canvas) return makeError(file.string(), ": ", canvas.error().message);
  return canvas->save(file);
}

}  // namespace evermap::eval
