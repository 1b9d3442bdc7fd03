#pragma once
// Top view of a trajectory evaluation: the ground truth and the aligned estimate drawn in one
// horizontal plane at equal scale on both axes, with grid, tick labels in metres, a scale bar,
// a legend and the start marked. PNG or SVG by the file's extension (canvas.h).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/so3.h"
#include "tools/eval/canvas.h"

namespace evermap::eval {

// The plane drawn: the first axis goes right, the second up. kAuto drops the axis along which
// the ground truth spans least (the vertical one): x-y for EuRoC and TUM, x-z for KITTI,
// whose camera frame has y pointing down.
enum class PlotPlane { kAuto, kXY, kXZ, kYZ };

// "auto", "xy", "xz", "yz".
const char* toString(PlotPlane plane);
Expected<PlotPlane> parsePlotPlane(std::string_view name);

struct TopViewOptions {
  std::string title;     // first line above the plot, e.g. the file names
  std::string subtitle;  // second line, e.g. the ATE figures
  std::string gt_label = "ground truth";
  std::string est_label = "estimate";
  PlotPlane plane = PlotPlane::kAuto;
  int width_px = 1000;  // image size, pixels (SVG user units)
  int height_px = 800;

  Status validate() const;
};

// Draws both position lists (same frame, metres). Errors: an empty or non-finite list, bad
// options.
Expected<Canvas> drawTopView(const std::vector<core::Vec3>& gt, const std::vector<core::Vec3>& est,
                             const TopViewOptions& options);

// drawTopView + Canvas::save (temporary file and rename). The error names the file.
Status writeTopView(const std::filesystem::path& file, const std::vector<core::Vec3>& gt,
                    const std::vector<core::Vec3>& est, const TopViewOptions& options);

// A line chart: y against x for several series, with linear axes from the data's range
// (y from 0 unless a value is negative), grid, tick labels and a legend.
struct ChartSeries {
  std::string label;
  std::vector<Eigen::Vector2d> points;  // (x, y), drawn in order
  Rgb color{31, 119, 180};
  bool dashed = false;
};

struct LineChartOptions {
  std::string title;
  std::string subtitle;
  std::string x_label;
  std::string y_label;
  int width_px = 1000;
  int height_px = 600;

  Status validate() const;
};

// Errors: no series, a series without points, a non-finite point, bad options.
Expected<Canvas> drawLineChart(const std::vector<ChartSeries>& series,
                               const LineChartOptions& options);
// drawLineChart + Canvas::save. The error names the file.
Status writeLineChart(const std::filesystem::path& file, const std::vector<ChartSeries>& series,
                      const LineChartOptions& options);

}  // namespace evermap::eval
