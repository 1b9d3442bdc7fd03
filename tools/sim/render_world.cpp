#include "tools/sim/render_world.h"

#include <algorithm>
#include <cmath>

namespace evermap::sim {
namespace {

constexpr uint8_t kBlankBit = 0x80;
constexpr uint8_t kLabelMask = 0x7f;

bool isCorridorPlace(PlaceKind k) {
  return k == PlaceKind::kJunction || k == PlaceKind::kDoor || k == PlaceKind::kLobby;
}

int pick(const std::vector<int>& ids, Random& rng) {
  return ids.empty() ? 0 : ids[static_cast<size_t>(rng.index(static_cast<int64_t>(ids.size())))];
}

class WallBuilder {
 public:
  WallBuilder(RenderFloor* floor, const WorldOptions& o, const TextureLibrary& lib, Random& rng)
      : f_(floor), o_(o), lib_(lib), rng_(rng) {}

  // A run of wall on the face of region `region` from p0 along e for `length`, normal n.
  void addRun(Vec2 p0, Vec2 e, Vec2 n, double length, int region, bool blank) {
    double s = 0.0;
    while (length - s > 1e-6) {
      double piece = rng_.uniform(o_.piece_min_m, o_.piece_max_m);
      if (length - s - piece < 0.5 * o_.piece_min_m) piece = length - s;
      addPiece(p0 + s * e, e, n, piece, region, blank);
      s += piece;
    }
  }

 private:
  void addPiece(Vec2 p0, Vec2 e, Vec2 n, double length, int region, bool blank) {
    const Region& r = f_->regions[static_cast<size_t>(region)];
    Wall w;
    w.p0x = static_cast<float>(p0.x());
    w.p0y = static_cast<float>(p0.y());
    w.ex = static_cast<float>(e.x());
    w.ey = static_cast<float>(e.y());
    w.nx = static_cast<float>(n.x());
    w.ny = static_cast<float>(n.y());
    w.length = static_cast<float>(length);
    w.region = region;
    w.texture = blank ? lib_.blank : (r.wall_texture >= 0 ? r.wall_texture : pick(lib_.wall, rng_));
    w.inv_texel = static_cast<float>(1.0 / rng_.uniform(o_.wall_texel_min_m, o_.wall_texel_max_m));
    const double size = lib_.textures[static_cast<size_t>(w.texture)].size();
    w.s_offset = static_cast<float>(rng_.uniform(0.0, size));
    w.z_offset = static_cast<float>(rng_.uniform(0.0, size));
    const double light = r.dark ? o_.dark_light : 1.0;
    const double jitter = blank ? 0.0 : rng_.uniform(-o_.brightness_jitter, o_.brightness_jitter);
    w.gain_q8 = static_cast<int>(std::lround(256.0 * light * (1.0 + jitter)));
    const double height = f_->ceiling_z - f_->floor_z;
    if (!blank && !lib_.posters.empty() && length >= 1.5 && rng_.bernoulli(o_.poster_probability)) {
      const double width =
          std::min(rng_.uniform(o_.poster_width_min_m, o_.poster_width_max_m), length - 0.3);
      const double tall = std::min(0.75 * width, height - 0.4);
      const double s0 = rng_.uniform(0.15, length - width - 0.15);
      const double zc =
          std::clamp(rng_.uniform(1.0, 1.7), 0.5 * tall + 0.1, height - 0.5 * tall - 0.1);
      w.poster =
          Poster{pick(lib_.posters, rng_), static_cast<float>(s0), static_cast<float>(s0 + width),
                 static_cast<float>(zc - 0.5 * tall), static_cast<float>(zc + 0.5 * tall)};
    }
    f_->walls.push_back(w);
  }

  RenderFloor* f_;
  const WorldOptions& o_;
  const TextureLibrary& lib_;
  Random& rng_;
};

// The label grid of a floor: origin and cell size in metres (doubles: the floats kept in
// RenderFloor are for the renderer), cells across.
struct GridFrame {
  double x0 = 0.0, y0 = 0.0, cell = 1.0;
  int w = 0, h = 0;
  Vec2 centre(int i, int j) const { return Vec2(x0 + (i + 0.5) * cell, y0 + (j + 0.5) * cell); }
};

// Each region's textures from the library's pools (one cab texture for the floor).
Status resolveTextures(const FloorSpec& spec, const TextureLibrary& lib, Random& rng,
                       RenderFloor* f) {
  const int cab_texture = lib.cab >= 0 ? lib.cab : pick(lib.wall, rng);
  for (Region& r : f->regions) {
    if (r.boxes.empty())
      return makeError("floor at z = ", spec.floor_z, ": a region without boxes");
    auto resolve = [&](int* t, const std::vector<int>& pool) {
      if (*t == kTexturePerRegion) *t = pick(pool, rng);
      if (*t == kTextureCab) *t = cab_texture;
    };
    resolve(&r.wall_texture, lib.wall);
    resolve(&r.floor_texture, lib.floor);
    resolve(&r.ceiling_texture, lib.ceiling);
    if (r.floor_texture < 0) r.floor_texture = pick(lib.floor, rng);
    if (r.ceiling_texture < 0) r.ceiling_texture = pick(lib.ceiling, rng);
  }
  return Ok{};
}

// Rasterise: cell centres inside a box get its region's label.
Expected<GridFrame> rasterise(const FloorSpec& spec, const WorldOptions& o, RenderFloor* f) {
  GridFrame g;
  const double cell = g.cell = o.grid_cell_m;
  Vec2 lo(1e18, 1e18), hi(-1e18, -1e18);
  for (const Region& r : spec.regions) {
    for (const Box& b : r.boxes) {
      lo = lo.cwiseMin(b.min);
      hi = hi.cwiseMax(b.max);
    }
  }
  const double x0 = g.x0 = (std::floor(lo.x() / cell) - 2.0) * cell;
  const double y0 = g.y0 = (std::floor(lo.y() / cell) - 2.0) * cell;
  const int w = g.w = static_cast<int>(std::ceil((hi.x() - x0) / cell)) + 2;
  const int h = g.h = static_cast<int>(std::ceil((hi.y() - y0) / cell)) + 2;
  if (static_cast<int64_t>(w) * h > 64'000'000) {
    return makeError("floor at z = ", spec.floor_z, ": ", w, " x ", h,
                     " grid cells is too many (grid_cell_m too small?)");
  }
  f->grid_x0 = static_cast<float>(x0);
  f->grid_y0 = static_cast<float>(y0);
  f->inv_cell = static_cast<float>(1.0 / cell);
  f->grid_w = w;
  f->grid_h = h;
  f->grid.assign(static_cast<size_t>(w) * h + kGatherPadBytes, 0);
  for (size_t r = 0; r < spec.regions.size(); ++r) {
    for (const Box& b : spec.regions[r].boxes) {
      const int i0 = std::max(0, static_cast<int>(std::floor((b.min.x() - x0) / cell)));
      const int i1 = std::min(w - 1, static_cast<int>(std::ceil((b.max.x() - x0) / cell)));
      const int j0 = std::max(0, static_cast<int>(std::floor((b.min.y() - y0) / cell)));
      const int j1 = std::min(h - 1, static_cast<int>(std::ceil((b.max.y() - y0) / cell)));
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          if (b.contains(g.centre(i, j)))
            f->grid[static_cast<size_t>(j) * w + i] = static_cast<uint8_t>(r + 1);
        }
      }
    }
  }
  return g;
}

// The blank bit on labelled cells within blank_radius_m of a blank centre.
void markBlanks(const FloorSpec& spec, const WorldOptions& o, const GridFrame& g, RenderFloor* f) {
  const double r2 = o.blank_radius_m * o.blank_radius_m;
  for (const Vec2& c : spec.blank_centres) {
    const int rad = static_cast<int>(std::ceil(o.blank_radius_m / g.cell));
    const int ci = static_cast<int>((c.x() - g.x0) / g.cell),
              cj = static_cast<int>((c.y() - g.y0) / g.cell);
    for (int j = std::max(0, cj - rad); j <= std::min(g.h - 1, cj + rad); ++j) {
      for (int i = std::max(0, ci - rad); i <= std::min(g.w - 1, ci + rad); ++i) {
        uint8_t& cell = f->grid[static_cast<size_t>(j) * g.w + i];
        if ((cell & kLabelMask) != 0 && (g.centre(i, j) - c).squaredNorm() <= r2) cell |= kBlankBit;
      }
    }
  }
}

// A wall between cells labelled a (its face) and b at `mid`, unless an opening joins them.
bool isWall(const FloorSpec& spec, uint8_t a, uint8_t b, const Vec2& mid) {
  const int la = a & kLabelMask, lb = b & kLabelMask;
  if (la == 0 || la == lb) return false;
  for (const Opening& op : spec.openings) {
    const bool pair = (op.a + 1 == la && op.b + 1 == lb) || (op.a + 1 == lb && op.b + 1 == la);
    if (pair && op.span.contains(mid)) return false;
  }
  return true;
}

// Walls: grid edges between different labels, outside openings. For every grid line and each
// side, runs of edges with the same (region, blank) become one run of wall.
void buildWalls(const FloorSpec& spec, const GridFrame& g, WallBuilder& builder,
                const RenderFloor& f) {
  const double x0 = g.x0, y0 = g.y0, cell = g.cell;
  // `vertical`: lines x = x0 + k * cell (walls along y); else lines y = y0 + k * cell.
  for (bool vertical : {true, false}) {
    const int lines = vertical ? g.w : g.h, along = vertical ? g.h : g.w;
    for (int k = 1; k < lines; ++k) {
      for (int side = 0; side < 2; ++side) {  // 0: the cell below k faces (normal -axis), 1: above
        int run_start = -1, run_key = -1;
        for (int m = 0; m <= along; ++m) {
          int key = -1;
          if (m < along) {
            const int ia = vertical ? k - 1 : m, ja = vertical ? m : k - 1;
            const int ib = vertical ? k : m, jb = vertical ? m : k;
            uint8_t a = f.grid[static_cast<size_t>(ja) * g.w + ia],
                    b = f.grid[static_cast<size_t>(jb) * g.w + ib];
            if (side == 1) std::swap(a, b);
            const Vec2 mid = vertical ? Vec2(x0 + k * cell, y0 + (m + 0.5) * cell)
                                      : Vec2(x0 + (m + 0.5) * cell, y0 + k * cell);
            if (isWall(spec, a, b, mid)) key = a;
          }
          if (key == run_key) continue;
          if (run_key >= 0) {
            const double s0 = run_start * cell, len = (m - run_start) * cell;
            const Vec2 p0 = vertical ? Vec2(x0 + k * cell, y0 + s0) : Vec2(x0 + s0, y0 + k * cell);
            const Vec2 e = vertical ? Vec2(0, 1) : Vec2(1, 0);
            const double sign = side == 0 ? -1.0 : 1.0;
            const Vec2 n = vertical ? Vec2(sign, 0) : Vec2(0, sign);
            builder.addRun(p0, e, n, len, (run_key & kLabelMask) - 1, (run_key & kBlankBit) != 0);
          }
          run_key = key;
          run_start = m;
        }
      }
    }
  }
}

}  // namespace

Status WorldOptions::validate() const {
  if (!(ceiling_height_m > 0.5)) return makeError("ceiling_height_m: must be > 0.5");
  if (!(grid_cell_m > 0.0 && grid_cell_m <= 0.5))
    return makeError("grid_cell_m: must be in (0, 0.5]");
  if (!(door_width_m > 0.0)) return makeError("door_width_m: must be > 0");
  if (!(piece_min_m > 0.0 && piece_max_m >= piece_min_m)) {
    return makeError("piece_min_m: need 0 < piece_min_m <= piece_max_m");
  }
  if (!(wall_texel_min_m > 0.0 && wall_texel_max_m >= wall_texel_min_m && floor_texel_m > 0.0 &&
        ceiling_texel_m > 0.0)) {
    return makeError("wall_texel_min_m: texel sizes must be > 0 and min <= max");
  }
  if (!(poster_probability >= 0.0 && poster_probability <= 1.0)) {
    return makeError("poster_probability: must be in [0, 1]");
  }
  if (!(poster_width_min_m > 0.0 && poster_width_max_m >= poster_width_min_m)) {
    return makeError("poster_width_min_m: need 0 < min <= max");
  }
  if (!(dark_light >= 0.0 && dark_light <= 1.0)) return makeError("dark_light: must be in [0, 1]");
  if (!(blank_radius_m >= 0.0)) return makeError("blank_radius_m: must be >= 0");
  if (!(brightness_jitter >= 0.0 && brightness_jitter < 1.0)) {
    return makeError("brightness_jitter: must be in [0, 1)");
  }
  return Ok{};
}

Expected<RenderFloor> buildRenderFloor(const FloorSpec& spec, const WorldOptions& o,
                                       const TextureLibrary& lib, Random& rng) {
  if (Status s = o.validate(); !s) return s.error();
  if (spec.regions.empty() || spec.regions.size() > kLabelMask - 1) {
    return makeError("floor at z = ", spec.floor_z, ": needs 1..126 regions, got ",
                     spec.regions.size());
  }
  RenderFloor f;
  f.floor_z = static_cast<float>(spec.floor_z);
  f.ceiling_z = static_cast<float>(spec.floor_z + o.ceiling_height_m);
  f.regions = spec.regions;
  if (Status s = resolveTextures(spec, lib, rng, &f); !s) return s.error();
  f.floor_gain_q8[0] = 256;
  f.floor_gain_q8[1] = static_cast<int>(std::lround(256.0 * o.dark_light));
  f.floor_inv_texel = static_cast<float>(1.0 / o.floor_texel_m);
  f.ceiling_inv_texel = static_cast<float>(1.0 / o.ceiling_texel_m);
  auto grid = rasterise(spec, o, &f);
  if (!grid) return grid.error();
  markBlanks(spec, o, *grid, &f);
  WallBuilder builder(&f, o, lib, rng);
  buildWalls(spec, *grid, builder, f);
  return f;
}

FloorSpec floorSpecOf(const Building& building, int floor, const BuildingOptions& bo,
                      const WorldOptions& o) {
  const Floor& fl = building.floors[static_cast<size_t>(floor)];
  const double hw = bo.corridor_half_width_m;
  FloorSpec spec;
  spec.floor_z = fl.height_m;
  Region corridors;
  corridors.wall_texture = kTexturePerPiece;
  for (size_t p = 0; p < fl.places.size(); ++p) {
    if (!isCorridorPlace(fl.places[p].kind)) continue;
    const Vec2 a = fl.places[p].xy;
    corridors.boxes.push_back(Box{a - Vec2(hw, hw), a + Vec2(hw, hw)});
    for (const Passage& e : fl.passages[p]) {
      if (static_cast<size_t>(e.to) < p || !isCorridorPlace(fl.places[e.to].kind)) continue;
      const Vec2 b = fl.places[e.to].xy;
      corridors.boxes.push_back(Box{a.cwiseMin(b) - Vec2(hw, hw), a.cwiseMax(b) + Vec2(hw, hw)});
    }
    if (fl.places[p].blank_wall) spec.blank_centres.push_back(a);
  }
  spec.regions.push_back(corridors);
  Region cab;
  cab.boxes.push_back(fl.cab);
  cab.wall_texture = kTextureCab;
  spec.regions.push_back(cab);
  const double door = 0.5 * o.door_width_m;
  if (fl.lobby >= 0) {
    const Vec2 l = fl.places[static_cast<size_t>(fl.lobby)].xy;
    spec.openings.push_back(Opening{
        0, 1,
        Box{Vec2(l.x() - door, fl.cab.min.y() - 0.2), Vec2(l.x() + door, fl.cab.min.y() + 0.2)}});
  }
  for (const Room& room : fl.rooms) {
    Region r;
    r.boxes.push_back(room.box);
    r.dark = room.dark;
    r.wall_texture = kTexturePerRegion;
    const int index = static_cast<int>(spec.regions.size());
    spec.regions.push_back(r);
    const Vec2 d = fl.places[static_cast<size_t>(room.door)].xy;
    spec.openings.push_back(Opening{
        0, index, Box{Vec2(d.x() - door, d.y() - hw - 0.2), Vec2(d.x() + door, d.y() + hw + 0.2)}});
  }
  return spec;
}

FloorSpec closedCabSpec(const Building& building) {
  FloorSpec spec;
  Region cab;
  cab.boxes.push_back(building.floors.front().cab);
  cab.wall_texture = kTextureCab;
  spec.regions.push_back(cab);
  return spec;
}

Expected<RenderWorld> buildRenderWorld(const Building& building, const BuildingOptions& bo,
                                       const WorldOptions& o, const TextureLibrary& lib,
                                       Random& rng) {
  RenderWorld world;
  for (size_t f = 0; f < building.floors.size(); ++f) {
    auto floor = buildRenderFloor(floorSpecOf(building, static_cast<int>(f), bo, o), o, lib, rng);
    if (!floor) return floor.error();
    world.floors.push_back(std::move(*floor));
  }
  auto cab = buildRenderFloor(closedCabSpec(building), o, lib, rng);
  if (!cab) return cab.error();
  world.closed_cab = std::move(*cab);
  return world;
}

}  // namespace evermap::sim
