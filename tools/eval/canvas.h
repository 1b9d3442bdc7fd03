#pragma once
// A small vector canvas for evaluation figures: lines, circles, rectangles and text in pixel
// coordinates (origin top left, y down), rendered either to PNG through OpenCV's drawing
// functions or to SVG text, so that both outputs of one figure share a single layout.
// Figures are built once and saved by file extension (.png or .svg).

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap::eval {

struct Rgb {
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
};

enum class TextAnchor { kStart, kMiddle, kEnd };

class Canvas {
 public:
  // Contract: width and height in [16, 16384] pixels.
  Canvas(int width_px, int height_px, Rgb background = {255, 255, 255});

  int width() const { return width_; }
  int height() const { return height_; }

  // An open polyline; `dashed` draws 6 px dashes with 4 px gaps.
  void polyline(std::vector<Eigen::Vector2d> points_px, Rgb color, double width_px,
                bool dashed = false);
  void line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, Rgb color, double width_px);
  void circle(const Eigen::Vector2d& center, double radius_px, Rgb color, bool filled);
  // Axis-aligned rectangle; `fill` is used only when `filled`.
  void rect(const Eigen::Vector2d& top_left, const Eigen::Vector2d& size, Rgb stroke,
            double stroke_px, bool filled = false, Rgb fill = {255, 255, 255});
  // A closed polygon filled with `fill` and outlined with `stroke` (none when stroke_px is 0).
  void polygon(std::vector<Eigen::Vector2d> points_px, Rgb stroke, double stroke_px, Rgb fill);
  // Text whose baseline passes through `at`; `size_px` is the height of a capital letter.
  void text(const Eigen::Vector2d& at, std::string s, double size_px, Rgb color,
            TextAnchor anchor = TextAnchor::kStart);

  // Rough width of `s` at `size_px`, the same for both renderers' layout decisions.
  static double textWidthPx(const std::string& s, double size_px);

  // Encoded files.
  Expected<std::string> encodePng() const;
  std::string encodeSvg() const;
  // Chooses PNG or SVG by the extension (case-insensitive) and writes through a temporary
  // file and a rename. Any other extension is an error naming the file.
  Status save(const std::filesystem::path& file) const;

 private:
  struct Item {
    enum Kind { kPolyline, kCircle, kRect, kText, kPolygon } kind = kPolyline;
    std::vector<Eigen::Vector2d> points;  // polyline points; circle/rect/text: [0] position
    Eigen::Vector2d size = Eigen::Vector2d::Zero();  // rect size
    Rgb stroke;
    Rgb fill;
    bool filled = false;
    bool dashed = false;
    double width_px = 1.0;  // stroke width, circle radius or text size
    std::string text;
    TextAnchor anchor = TextAnchor::kStart;
  };
  // A new item of `kind` with its common fields; the caller sets the rest.
  Item& add(Item::Kind kind, std::vector<Eigen::Vector2d> points, Rgb stroke, double width_px);

  int width_;
  int height_;
  Rgb background_;
  std::vector<Item> items_;
};

}  // namespace evermap::eval
