#include "tools/map-export/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace evermap::map_export {

Status GridOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (!(band_max_m > band_min_m)) return Error("band_max_m: must be above band_min_m");
  return Ok{};
}

OccupancyGrid::OccupancyGrid(double x0, double y0, int width, int height, double resolution_m)
    : x0_(x0), y0_(y0), res_(resolution_m), width_(width), height_(height) {
  if (!(resolution_m > 0.0) || width < 0 || height < 0) {
    std::fprintf(stderr, "OccupancyGrid: resolution %g, %d x %d cells\n", resolution_m, width,
                 height);
    std::abort();
  }
  hits_.assign(static_cast<size_t>(width) * height, 0);
  misses_.assign(hits_.size(), 0);
}

OccupancyGrid OccupancyGrid::covering(const std::vector<Scan>& scans, const GridOptions& o) {
  double lo_x = std::numeric_limits<double>::infinity(), lo_y = lo_x, hi_x = -lo_x, hi_y = -lo_x;
  auto take = [&](const core::Vec3& p) {
    lo_x = std::min(lo_x, p.x());
    lo_y = std::min(lo_y, p.y());
    hi_x = std::max(hi_x, p.x());
    hi_y = std::max(hi_y, p.y());
  };
  for (const Scan& s : scans) {
    take(s.camera);
    for (const core::Vec3& p : s.points)
      if ((p - s.camera).norm() <= o.max_range_m) take(p);
  }
  const double res = o.resolution_m;
  if (!(hi_x >= lo_x)) return OccupancyGrid(0.0, 0.0, 0, 0, res);
  // Cell edges on multiples of the resolution: two exports of one map share their cells.
  const double x0 = std::floor((lo_x - o.margin_m) / res) * res;
  const double y0 = std::floor((lo_y - o.margin_m) / res) * res;
  const int w = static_cast<int>(std::ceil((hi_x + o.margin_m - x0) / res));
  const int h = static_cast<int>(std::ceil((hi_y + o.margin_m - y0) / res));
  OccupancyGrid g(x0, y0, w, h, res);
  g.setCellRule(o.min_hits, o.occupied_fraction);
  return g;
}

bool OccupancyGrid::cellOf(double x, double y, int* i, int* j) const {
  const double fi = std::floor((x - x0_) / res_), fj = std::floor((y - y0_) / res_);
  if (!(fi >= 0 && fj >= 0 && fi < width_ && fj < height_)) return false;
  *i = static_cast<int>(fi);
  *j = static_cast<int>(fj);
  return true;
}

core::Vec2 OccupancyGrid::centre(int i, int j) const {
  return core::Vec2(x0_ + (i + 0.5) * res_, y0_ + (j + 0.5) * res_);
}

// Amanatides & Woo (1987) traversal of the cells the segment a -> b crosses.
void OccupancyGrid::ray(const core::Vec2& a, const core::Vec2& b) {
  const core::Vec2 fa((a.x() - x0_) / res_, (a.y() - y0_) / res_);
  const core::Vec2 fb((b.x() - x0_) / res_, (b.y() - y0_) / res_);
  int i = static_cast<int>(std::floor(fa.x())), j = static_cast<int>(std::floor(fa.y()));
  const int bi = static_cast<int>(std::floor(fb.x())), bj = static_cast<int>(std::floor(fb.y()));
  const core::Vec2 d = fb - fa;
  const int si = d.x() > 0 ? 1 : -1, sj = d.y() > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double dx = d.x() != 0 ? std::abs(1.0 / d.x()) : inf;
  const double dy = d.y() != 0 ? std::abs(1.0 / d.y()) : inf;
  double tx = d.x() != 0 ? (d.x() > 0 ? (i + 1 - fa.x()) : (fa.x() - i)) * dx : inf;
  double ty = d.y() != 0 ? (d.y() > 0 ? (j + 1 - fa.y()) : (fa.y() - j)) * dy : inf;
  const int steps = std::abs(bi - i) + std::abs(bj - j);
  for (int n = 0; n < steps; ++n) {
    if (i >= 0 && j >= 0 && i < width_ && j < height_) ++misses_[index(i, j)];
    if (tx < ty) {
      i += si;
      tx += dx;
    } else {
      j += sj;
      ty += dy;
    }
  }
}

void OccupancyGrid::addScan(const Scan& scan, double floor_z, const GridOptions& o) {
  const double lo = floor_z + o.band_min_m, hi = floor_z + o.band_max_m;
  const core::Vec3& c = scan.camera;
  for (const core::Vec3& p : scan.points) {
    if (!((p - c).norm() <= o.max_range_m)) continue;
    // The part of c + t (p - c), t in [0, 1], inside the band.
    double t0 = 0.0, t1 = 1.0;
    const double dz = p.z() - c.z();
    if (dz != 0.0) {
      const double ta = (lo - c.z()) / dz, tb = (hi - c.z()) / dz;
      t0 = std::max(t0, std::min(ta, tb));
      t1 = std::min(t1, std::max(ta, tb));
    } else if (c.z() < lo || c.z() > hi) {
      continue;
    }
    if (t0 >= t1) continue;
    const core::Vec3 a = c + t0 * (p - c), b = c + t1 * (p - c);
    ray(a.head<2>(), b.head<2>());
    int i = 0, j = 0;
    if (!cellOf(b.x(), b.y(), &i, &j)) continue;
    if (t1 >= 1.0)
      ++hits_[index(i, j)];  // the point itself is in the band: an obstacle
    else
      ++misses_[index(i, j)];
  }
}

Cell OccupancyGrid::cell(int i, int j) const {
  const uint32_t h = hits_[index(i, j)], m = misses_[index(i, j)];
  if (h >= static_cast<uint32_t>(min_hits_) && h >= occupied_fraction_ * (h + m))
    return Cell::kOccupied;
  return m > 0 ? Cell::kFree : Cell::kUnknown;
}

std::string OccupancyGrid::pgm() const {
  std::string out = "P5\n" + std::to_string(width_) + " " + std::to_string(height_) + "\n255\n";
  const size_t header = out.size();
  out.resize(header + hits_.size());
  for (int j = 0; j < height_; ++j) {
    for (int i = 0; i < width_; ++i) {
      const Cell c = cell(i, j);
      const uint8_t v = c == Cell::kOccupied ? 0 : (c == Cell::kFree ? 254 : 205);
      out[header + static_cast<size_t>(height_ - 1 - j) * width_ + i] = static_cast<char>(v);
    }
  }
  return out;
}

std::string OccupancyGrid::yaml(const std::string& image) const {
  char buf[512];
  // origin: the map-frame pose of the image's lower-left pixel (x, y, yaw).
  std::snprintf(buf, sizeof buf,
                "image: %s\nmode: trinary\nresolution: %.6f\norigin: [%.6f, %.6f, 0.0]\n"
                "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
                image.c_str(), res_, x0_, y0_);
  return buf;
}

}  // namespace evermap::map_export
