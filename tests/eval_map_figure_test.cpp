#include "tools/eval/map_figure.h"

#include <gtest/gtest.h>

#include <regex>

namespace evermap::eval {
namespace {

// A square loop of 8 nodes on each of three floors, 3 m apart, one session per floor.
MapFigure threeFloors() {
  MapFigure f;
  for (int floor = 0; floor < 3; ++floor) {
    const size_t first = f.nodes.size();
    for (int k = 0; k < 8; ++k) {
      const double x = k < 4 ? 10.0 * k : 10.0 * (7 - k);
      const double y = k < 4 ? 0.0 : 20.0;
      f.nodes.push_back({core::Vec3(x, y, 3.0 * floor), floor, floor + 1});
      if (k > 0) f.edges.push_back({first + k - 1, first + k, false});
    }
    f.edges.push_back({first + 7, first, true});
  }
  return f;
}

std::vector<double> circleYs(const std::string& svg) {
  std::vector<double> ys;
  const std::regex re("<circle cx=\"[^\"]+\" cy=\"([^\"]+)\" r=\"1.60\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    ys.push_back(std::stod((*it)[1]));
  }
  return ys;
}

TEST(MapFigure, DrawsOnePlatePerFloorAndStacksThemUpwards) {
  MapFigureSummary summary;
  auto canvas = drawMapFigure(threeFloors(), MapFigureOptions{}, &summary);
  ASSERT_TRUE(canvas.ok()) << canvas.error().message;
  EXPECT_EQ(summary.floors, 3u);
  EXPECT_EQ(summary.sessions, 3u);
  EXPECT_EQ(summary.loop_closures, 3u);
  const std::string svg = canvas->encodeSvg();
  size_t plates = 0;
  for (size_t at = svg.find("<polygon"); at != std::string::npos;
       at = svg.find("<polygon", at + 1)) {
    ++plates;
  }
  EXPECT_EQ(plates, 3u);
  EXPECT_NE(svg.find("floor 2  (6.0 m)"), std::string::npos);
  // Nodes are drawn floor by floor from the bottom; every node of a higher floor lies higher
  // on the page (smaller y) than the same node one floor down.
  const std::vector<double> ys = circleYs(svg);
  ASSERT_EQ(ys.size(), 24u);
  for (size_t k = 0; k < 8; ++k) {
    EXPECT_LT(ys[8 + k], ys[k]);
    EXPECT_LT(ys[16 + k], ys[8 + k]);
  }
}

TEST(MapFigure, RefusesBrokenInput) {
  MapFigure f = threeFloors();
  f.edges.push_back({0, 99, false});
  auto bad_edge = drawMapFigure(f, MapFigureOptions{});
  ASSERT_FALSE(bad_edge.ok());
  EXPECT_NE(bad_edge.error().message.find("missing node"), std::string::npos);

  f = threeFloors();
  f.nodes[3].p_world.x() = std::nan("");
  auto nan = drawMapFigure(f, MapFigureOptions{});
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("node 3"), std::string::npos);

  EXPECT_FALSE(drawMapFigure(MapFigure{}, MapFigureOptions{}).ok());
  MapFigureOptions flat;
  flat.flatten = 0.0;
  EXPECT_FALSE(drawMapFigure(threeFloors(), flat).ok());
}

TEST(MapFigure, EncodesPngWithTheReference) {
  MapFigure f = threeFloors();
  for (int i = 0; i <= 60; ++i) f.reference.push_back(core::Vec3(0.5 * i, 1.0, 0.1 * i));
  auto canvas = drawMapFigure(f, MapFigureOptions{});
  ASSERT_TRUE(canvas.ok());
  auto png = canvas->encodePng();
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png->substr(1, 3), "PNG");
  EXPECT_NE(canvas->encodeSvg().find("ground truth"), std::string::npos);
}

}  // namespace
}  // namespace evermap::eval
