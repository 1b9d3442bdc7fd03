// tools/eval/plot and canvas: the top view keeps equal scale, picks the horizontal plane,
// writes PNG and SVG through a temporary file, and rejects what it cannot draw.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "scratch_dir.h"
#include "tools/eval/plot.h"

namespace evermap::eval {
namespace {

namespace fs = std::filesystem;

std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A 40 m x 40 m square in the x-y plane, and the same square 2 m to the right.
std::vector<core::Vec3> square(double dx) {
  std::vector<core::Vec3> pts;
  for (int k = 0; k <= 400; ++k) {
    const double s = 0.4 * k;  // metres along the perimeter, 0..160
    const int side = std::min(3, static_cast<int>(s / 40.0));
    const double f = s - 40.0 * side;
    const core::Vec3 corner[4] = {{0, 0, 1}, {40, 0, 1}, {40, 40, 1}, {0, 40, 1}};
    const core::Vec3 dir[4] = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
    pts.push_back(corner[side] + f * dir[side] + core::Vec3(dx, 0, 0));
  }
  return pts;
}

TEST(TopViewPlot, PngKeepsEqualScaleOnBothAxes) {
  const testing::ScratchDir dir;
  TopViewOptions options;
  options.title = "square";
  const auto gt = square(0.0);
  ASSERT_TRUE(writeTopView(dir / "square.png", gt, gt, options).ok());
  const cv::Mat img = cv::imread((dir / "square.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1000);
  EXPECT_EQ(img.rows, 800);
  // The estimate's blue (BGR 180, 119, 31) outlines the square: its bounding box is square.
  int x0 = img.cols, x1 = -1, y0 = img.rows, y1 = -1;
  for (int y = 100; y < img.rows; ++y) {  // below the legend row
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      if (std::abs(p[0] - 180) < 40 && std::abs(p[1] - 119) < 40 && p[2] < 90) {
        x0 = std::min(x0, x);
        x1 = std::max(x1, x);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
      }
    }
  }
  ASSERT_GT(x1, x0);
  // 40 m drawn at the same pixels per metre on both axes.
  EXPECT_NEAR(x1 - x0, y1 - y0, 4) << x0 << " " << x1 << " " << y0 << " " << y1;
  EXPECT_GT(y1 - y0, 400);  // the square fills most of the 664-pixel-high plot area
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(TopViewPlot, SvgHasBothPathsTheLabelsEscapedAndThePlaneNamed) {
  const testing::ScratchDir dir;
  TopViewOptions options;
  options.est_label = "est <a&b>";
  // KITTI-like: y (down) barely changes, so the auto plane is x-z.
  std::vector<core::Vec3> gt, est;
  for (int k = 0; k < 100; ++k) {
    gt.push_back(core::Vec3(0.1 * k * k / 10.0, 0.01 * std::sin(k), k));
    est.push_back(gt.back() + core::Vec3(0.5, 0, 0));
  }
  ASSERT_TRUE(writeTopView(dir / "top.SVG", gt, est, options).ok());
  const std::string svg = readAll(dir / "top.SVG");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("est &lt;a&amp;b&gt;"), std::string::npos);
  EXPECT_NE(svg.find(">z [m]<"), std::string::npos);
  EXPECT_NE(svg.find(">x [m]<"), std::string::npos);
  EXPECT_NE(svg.find("stroke=\"#1f77b4\""), std::string::npos);
  EXPECT_NE(svg.find("stroke=\"#000000\""), std::string::npos);

  options.plane = PlotPlane::kXY;
  const auto xy = drawTopView(gt, est, options);
  ASSERT_TRUE(xy.ok());
  EXPECT_NE(xy->encodeSvg().find(">y [m]<"), std::string::npos);
}

TEST(TopViewPlot, BadInputsAreErrors) {
  const testing::ScratchDir dir;
  const auto gt = square(0.0);
  auto s = writeTopView(dir / "top.jpg", gt, gt, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("top.jpg: unknown figure type"), std::string::npos);
  s = writeTopView(dir / "top.png", {}, gt, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("top.png: plot: nothing to draw"), std::string::npos);
  std::vector<core::Vec3> nan = gt;
  nan[5].y() = std::nan("");
  EXPECT_FALSE(writeTopView(dir / "top.png", gt, nan, {}).ok());
  TopViewOptions tiny;
  tiny.width_px = 10;
  EXPECT_FALSE(writeTopView(dir / "top.png", gt, gt, tiny).ok());
  EXPECT_FALSE(writeTopView(dir / "missing/top.png", gt, gt, {}).ok());
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 0);
  EXPECT_FALSE(parsePlotPlane("top").ok());
}

TEST(TopViewPlot, ASinglePointStillDraws) {
  const std::vector<core::Vec3> one = {core::Vec3(1, 2, 3)};
  const auto c = drawTopView(one, one, {});
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->encodePng().ok());
}

}  // namespace
}  // namespace evermap::eval
