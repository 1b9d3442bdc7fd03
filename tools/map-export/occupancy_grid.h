#pragma once
// A floor's occupancy grid from 3-D points seen by a camera (evermap-map-export): the cells a
// ray from the camera to a point crosses inside the robot's height band are counted free
// (misses), the cell of a point inside the band is counted occupied (a hit). Counts, not
// log-odds: a cell is occupied when it has at least min_hits hits and hits make at least
// occupied_fraction of its rays, free when it was crossed and is not occupied, else unknown.
// Written in ROS map_server's format (a PGM and its YAML; occupied 0, free 254, unknown 205,
// as map_saver writes them).
//
// Frames: points and cameras are in the map frame (z up); the band is measured from the
// floor's surface z. Only the part of a ray inside the band clears cells (a point on the floor
// or the ceiling still frees the cells its ray crosses at the robot's height).

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::map_export {

struct GridOptions {
  double resolution_m = 0.05;  // cell side
  double band_min_m = 0.1;     // the robot's height band above the floor surface
  double band_max_m = 1.5;
  double max_range_m = 5.0;        // points farther from their camera are not used
  int min_hits = 2;                // hits a cell needs to be occupied
  double occupied_fraction = 0.3;  // and hits / (hits + misses) at least this
  double margin_m = 1.0;           // around the floor's cameras and points

  void declareOptions(OptionList& o) {
    o.add("resolution_m", &resolution_m, "m", "cell side of the floor plans").in(0.01, 1.0);
    o.add("band_min_m", &band_min_m, "m",
          "lowest obstacle height above the floor (the body origins' median height)")
        .any();
    o.add("band_max_m", &band_max_m, "m", "highest obstacle height above the floor (robot)").any();
    o.add("max_range_m", &max_range_m, "m", "points farther from their camera are left out")
        .positive();
    o.add("min_hits", &min_hits, "", "points a cell needs to be occupied").min(1);
    o.add("occupied_fraction", &occupied_fraction, "",
          "share of a cell's rays that must end in it for it to be occupied")
        .in(0, 1);
    o.add("margin_m", &margin_m, "m", "grid margin around the floor's points").min(0);
  }
  Status validate() const;
};

// One camera and the points it saw, map frame.
struct Scan {
  core::Vec3 camera = core::Vec3::Zero();
  std::vector<core::Vec3> points;
};

enum class Cell : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

class OccupancyGrid {
 public:
  // Cells covering [x0, x0 + width * res) x [y0, y0 + height * res); contract: res > 0.
  OccupancyGrid(double x0, double y0, int width, int height, double resolution_m);
  // The grid that covers every scan's camera and in-range point plus the margin.
  static OccupancyGrid covering(const std::vector<Scan>& scans, const GridOptions& o);

  // Counts one scan's rays; floor_z is the floor surface's height in the map frame.
  void addScan(const Scan& scan, double floor_z, const GridOptions& o);
  Cell cell(int i, int j) const;  // i along x, j along y
  // The cell holding (x, y); false when outside.
  bool cellOf(double x, double y, int* i, int* j) const;
  core::Vec2 centre(int i, int j) const;
  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return res_; }
  double x0() const { return x0_; }
  double y0() const { return y0_; }
  void setCellRule(int min_hits, double occupied_fraction) {
    min_hits_ = min_hits;
    occupied_fraction_ = occupied_fraction;
  }

  // map_server's image: binary PGM (P5), the top row is the largest y.
  std::string pgm() const;
  // map_server's YAML for `image` (a file name beside it).
  std::string yaml(const std::string& image) const;

 private:
  void ray(const core::Vec2& a, const core::Vec2& b);  // misses from a up to, not at, b
  size_t index(int i, int j) const { return static_cast<size_t>(j) * width_ + i; }

  double x0_, y0_, res_;
  int width_, height_;
  int min_hits_ = 2;
  double occupied_fraction_ = 0.3;
  std::vector<uint32_t> hits_, misses_;
};

}  // namespace evermap::map_export
