#include "tools/eval/canvas.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/common/atomic_write.h"

namespace evermap::eval {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
// SVG font sizes are em sizes; a capital of a sans-serif face is about 0.72 em tall.
constexpr double kCapHeightEm = 0.72;

double fontScaleFor(double size_px) {
  static const double cap_at_1 = [] {
    int baseline = 0;
    return static_cast<double>(cv::getTextSize("H", kFont, 1.0, 1, &baseline).height);
  }();
  return size_px / cap_at_1;
}

int thicknessFor(double size_px) {
  return std::max(1, static_cast<int>(std::lround(size_px / 11.0)));
}

cv::Scalar bgr(Rgb c) { return cv::Scalar(c.b, c.g, c.r); }
cv::Point px(const Eigen::Vector2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
}
int strokeFor(double width_px) { return std::max(1, static_cast<int>(std::lround(width_px))); }

std::string svgColor(Rgb c) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "#%02x%02x%02x", c.r, c.g, c.b);
  return buf;
}

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", v);
  return buf;
}

// Splits a polyline into dashes of `on` pixels separated by `off` pixels.
std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> dashes(
    const std::vector<Eigen::Vector2d>& pts, double on, double off) {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> out;
  double phase = 0.0;  // distance into the current on+off period
  for (size_t i = 1; i < pts.size(); ++i) {
    const Eigen::Vector2d d = pts[i] - pts[i - 1];
    const double len = d.norm();
    double s = 0.0;
    while (s < len) {
      const bool drawing = phase < on;
      const double step = std::min(len - s, drawing ? on - phase : on + off - phase);
      if (drawing)
        out.emplace_back(pts[i - 1] + d * (s / len), pts[i - 1] + d * ((s + step) / len));
      s += step;
      phase = std::fmod(phase + step, on + off);
    }
  }
  return out;
}

}  // namespace

Canvas::Canvas(int width_px, int height_px, Rgb background)
    : width_(width_px), height_(height_px), background_(background) {
  if (width_px < 16 || height_px < 16 || width_px > 16384 || height_px > 16384) {
    std::fprintf(stderr, "evermap: Canvas size %dx%d out of range\n", width_px, height_px);
    std::abort();
  }
}

Canvas::Item& Canvas::add(Item::Kind kind, std::vector<Eigen::Vector2d> points, Rgb stroke,
                          double width_px) {
  Item& it = items_.emplace_back();
  it.kind = kind;
  it.points = std::move(points);
  it.stroke = stroke;
  it.width_px = width_px;
  return it;
}

void Canvas::polyline(std::vector<Eigen::Vector2d> points_px, Rgb color, double width_px,
                      bool dashed) {
  add(Item::kPolyline, std::move(points_px), color, width_px).dashed = dashed;
}

void Canvas::line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, Rgb color, double width_px) {
  polyline({a, b}, color, width_px);
}

void Canvas::circle(const Eigen::Vector2d& center, double radius_px, Rgb color, bool filled) {
  Item& it = add(Item::kCircle, {center}, color, radius_px);
  it.fill = color;
  it.filled = filled;
}

void Canvas::rect(const Eigen::Vector2d& top_left, const Eigen::Vector2d& size, Rgb stroke,
                  double stroke_px, bool filled, Rgb fill) {
  Item& it = add(Item::kRect, {top_left}, stroke, stroke_px);
  it.size = size;
  it.fill = fill;
  it.filled = filled;
}

void Canvas::polygon(std::vector<Eigen::Vector2d> points_px, Rgb stroke, double stroke_px,
                     Rgb fill) {
  Item& it = add(Item::kPolygon, std::move(points_px), stroke, stroke_px);
  it.fill = fill;
  it.filled = true;
}

void Canvas::text(const Eigen::Vector2d& at, std::string s, double size_px, Rgb color,
                  TextAnchor anchor) {
  Item& it = add(Item::kText, {at}, color, size_px);
  it.text = std::move(s);
  it.anchor = anchor;
}

double Canvas::textWidthPx(const std::string& s, double size_px) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, fontScaleFor(size_px), thicknessFor(size_px), &baseline).width;
}

Expected<std::string> Canvas::encodePng() const {
  cv::Mat img(height_, width_, CV_8UC3, bgr(background_));
  for (const Item& it : items_) {
    switch (it.kind) {
      case Item::kPolyline: {
        if (it.dashed) {
          for (const auto& [a, b] : dashes(it.points, 6.0, 4.0)) {
            cv::line(img, px(a), px(b), bgr(it.stroke), strokeFor(it.width_px), cv::LINE_AA);
          }
        } else {
          std::vector<cv::Point> pts;
          pts.reserve(it.points.size());
          for (const auto& p : it.points) pts.push_back(px(p));
          cv::polylines(img, pts, false, bgr(it.stroke), strokeFor(it.width_px), cv::LINE_AA);
        }
        break;
      }
      case Item::kPolygon: {
        std::vector<cv::Point> pts;
        pts.reserve(it.points.size());
        for (const auto& p : it.points) pts.push_back(px(p));
        if (pts.size() < 3) break;
        cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, bgr(it.fill), cv::LINE_AA);
        if (it.width_px > 0) {
          cv::polylines(img, pts, true, bgr(it.stroke), strokeFor(it.width_px), cv::LINE_AA);
        }
        break;
      }
      case Item::kCircle:
        cv::circle(img, px(it.points[0]), static_cast<int>(std::lround(it.width_px)),
                   bgr(it.stroke), it.filled ? cv::FILLED : 2, cv::LINE_AA);
        break;
      case Item::kRect: {
        const cv::Rect r(px(it.points[0]), px(it.points[0] + it.size));
        if (it.filled) cv::rectangle(img, r, bgr(it.fill), cv::FILLED);
        cv::rectangle(img, r, bgr(it.stroke), strokeFor(it.width_px), cv::LINE_8);
        break;
      }
      case Item::kText: {
        const double w = textWidthPx(it.text, it.width_px);
        Eigen::Vector2d at = it.points[0];
        if (it.anchor == TextAnchor::kMiddle) at.x() -= 0.5 * w;
        if (it.anchor == TextAnchor::kEnd) at.x() -= w;
        cv::putText(img, it.text, px(at), kFont, fontScaleFor(it.width_px), bgr(it.stroke),
                    thicknessFor(it.width_px), cv::LINE_AA);
        break;
      }
    }
  }
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", img, bytes)) return makeError("PNG encoding failed");
  return std::string(bytes.begin(), bytes.end());
}

std::string Canvas::encodeSvg() const {
  std::string s;
  s += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  s += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width_) +
       "\" height=\"" + std::to_string(height_) + "\" viewBox=\"0 0 " + std::to_string(width_) +
       " " + std::to_string(height_) + "\" font-family=\"Helvetica, Arial, sans-serif\">\n";
  s += "<rect width=\"100%\" height=\"100%\" fill=\"" + svgColor(background_) + "\"/>\n";
  for (const Item& it : items_) {
    switch (it.kind) {
      case Item::kPolyline: {
        s += "<polyline fill=\"none\" stroke=\"" + svgColor(it.stroke) + "\" stroke-width=\"" +
             num(it.width_px) + "\" stroke-linejoin=\"round\" stroke-linecap=\"round\"";
        if (it.dashed) s += " stroke-dasharray=\"6,4\"";
        s += " points=\"";
        for (size_t i = 0; i < it.points.size(); ++i) {
          if (i > 0) s += ' ';
          s += num(it.points[i].x()) + "," + num(it.points[i].y());
        }
        s += "\"/>\n";
        break;
      }
      case Item::kPolygon: {
        s += "<polygon fill=\"" + svgColor(it.fill) + "\" stroke=\"" +
             (it.width_px > 0 ? svgColor(it.stroke) : std::string("none")) + "\" stroke-width=\"" +
             num(it.width_px) + "\" stroke-linejoin=\"round\" points=\"";
        for (size_t i = 0; i < it.points.size(); ++i) {
          if (i > 0) s += ' ';
          s += num(it.points[i].x()) + "," + num(it.points[i].y());
        }
        s += "\"/>\n";
        break;
      }
      case Item::kCircle:
        s += "<circle cx=\"" + num(it.points[0].x()) + "\" cy=\"" + num(it.points[0].y()) +
             "\" r=\"" + num(it.width_px) + "\" ";
        s += it.filled
                 ? "fill=\"" + svgColor(it.fill) + "\"/>\n"
                 : "fill=\"none\" stroke=\"" + svgColor(it.stroke) + "\" stroke-width=\"2\"/>\n";
        break;
      case Item::kRect:
        s += "<rect x=\"" + num(it.points[0].x()) + "\" y=\"" + num(it.points[0].y()) +
             "\" width=\"" + num(it.size.x()) + "\" height=\"" + num(it.size.y()) + "\" fill=\"" +
             (it.filled ? svgColor(it.fill) : std::string("none")) + "\" stroke=\"" +
             svgColor(it.stroke) + "\" stroke-width=\"" + num(it.width_px) + "\"/>\n";
        break;
      case Item::kText: {
        const char* anchor = it.anchor == TextAnchor::kStart    ? "start"
                             : it.anchor == TextAnchor::kMiddle ? "middle"
                                                                : "end";
        s += "<text x=\"" + num(it.points[0].x()) + "\" y=\"" + num(it.points[0].y()) +
             "\" font-size=\"" + num(it.width_px / kCapHeightEm) + "\" fill=\"" +
             svgColor(it.stroke) + "\" text-anchor=\"" + anchor + "\">" + xmlEscape(it.text) +
             "</text>\n";
        break;
      }
    }
  }
  s += "</svg>\n";
  return s;
}

Status Canvas::save(const std::filesystem::path& file) const {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".svg") return writeFileAtomically(file, encodeSvg());
  if (ext == ".png") {
    auto png = encodePng();
    if (!png) return makeError(file.string(), ": ", png.error().message);
    return writeFileAtomically(file, *png);
  }
  return makeError(file.string(), ": unknown figure type \"", ext, "\" (expected .png or .svg)");
}

}  // namespace evermap::eval
