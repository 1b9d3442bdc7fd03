#pragma once
// The textured geometry the image-level simulator renders (DESIGN.md section 8): each floor of
// a Building (building.h) as vertical wall rectangles from floor to ceiling, plus a floor and
// a ceiling plane, all painted with TextureLibrary textures.
//
// A floor is first described as regions (axis-aligned boxes: the corridors, each room, the
// elevator cab) and openings (doors). The regions are rasterised on a fine grid; a wall is
// every grid edge between a region and anything else (solid or another region), except the
// edges of an opening between its two regions. Collinear edges merge into segments that are cut
// into pieces of a few metres, each with its own texture, brightness and sometimes a poster.
// A wall is one-sided: it faces into the region it belongs to (two rooms sharing a wall get a
// face each). The grid also answers "which region is this floor point in" for floor/ceiling
// shading, and which points are in a featureless zone.
//
// Units: metres; world frame z up (motion.h). Wall texture coordinates: s along the wall from
// p0, z above the floor surface.

#include <cstdint>
#include <vector>

#include "core/common/expected.h"
#include "tools/sim/building.h"
#include "tools/sim/random.h"
#include "tools/sim/textures.h"

namespace evermap::sim {

struct WorldOptions {
  double ceiling_height_m = 2.8;  // above each floor surface
  double grid_cell_m = 0.05;      // rasterisation of the regions
  double door_width_m = 1.2;      // room doors and the elevator door
  double piece_min_m = 2.0;       // walls are cut into pieces of [min, max] metres
  double piece_max_m = 6.0;
  double wall_texel_min_m = 0.008;  // texel size of wall textures, drawn per piece
  double wall_texel_max_m = 0.016;
  double floor_texel_m = 0.012;
  double ceiling_texel_m = 0.02;
  double poster_probability = 0.35;  // per wall piece at least 1.5 m long
  double poster_width_min_m = 0.6;
  double poster_width_max_m = 1.1;
  double dark_light = 0.04;         // light level of a room with the lights off (lit: 1)
  double blank_radius_m = 4.0;      // featureless zone around a blank-wall junction
  double brightness_jitter = 0.25;  // each wall piece is lit 1 ± this

  Status validate() const;
};

struct Poster {
  int texture = -1;
  float s0 = 0, s1 = 0, z0 = 0, z1 = 0;  // rectangle on the wall, metres
};

struct Wall {
  // The segment p0 + s * e, 0 <= s <= length; n is the unit normal into the region.
  float p0x = 0, p0y = 0, ex = 0, ey = 0, nx = 0, ny = 0, length = 0;
  int region = 0;
  int texture = -1;
  float inv_texel = 100.0f;          // texels per metre
  float s_offset = 0, z_offset = 0;  // texture offset, texels
  int gain_q8 = 256;                 // brightness * 256 (light of the region included)
  Poster poster;
};

// Texture choices of a region: a library index, or one of these.
inline constexpr int kTexturePerPiece = -1;   // walls: a random wall texture per piece
inline constexpr int kTexturePerRegion = -2;  // one random texture for the whole region
inline constexpr int kTextureCab = -3;        // the elevator cab's texture

struct Region {
  std::vector<Box> boxes;  // the union is the region
  bool dark = false;
  int floor_texture = kTexturePerRegion;
  int ceiling_texture = kTexturePerRegion;
  int wall_texture = kTexturePerPiece;
};

// Between regions a and b, no wall on the grid edges inside `span`.
struct Opening {
  int a = 0, b = 0;  // region indices (0-based into FloorSpec::regions)
  Box span;
};

struct FloorSpec {
  double floor_z = 0.0;
  std::vector<Region> regions;
  std::vector<Opening> openings;
  std::vector<Vec2> blank_centres;  // featureless zones (blank_radius_m around each)
};

// A floor ready to render.
struct RenderFloor {
  float floor_z = 0, ceiling_z = 0;
  std::vector<Wall> walls;
  std::vector<Region> regions;
  // Grid: label 0 solid, r + 1 region r; bit 7 set: featureless zone. Row-major, grid_w x
  // grid_h, then kGatherPadBytes spare bytes.
  float grid_x0 = 0, grid_y0 = 0, inv_cell = 20.0f;
  int grid_w = 0, grid_h = 0;
  std::vector<uint8_t> grid;
  int floor_gain_q8[2] = {256, 256};  // lit, dark (floor and ceiling brightness)
  float floor_inv_texel = 80.0f, ceiling_inv_texel = 50.0f;  // texels per metre

  // The grid cell of a point (clamped to the grid).
  uint8_t cellAt(float x, float y) const {
    int i = static_cast<int>((x - grid_x0) * inv_cell),
        j = static_cast<int>((y - grid_y0) * inv_cell);
    i = i < 0 ? 0 : (i >= grid_w ? grid_w - 1 : i);
    j = j < 0 ? 0 : (j >= grid_h ? grid_h - 1 : j);
    return grid[static_cast<size_t>(j) * grid_w + i];
  }
};

// Builds the walls of a floor. At most 126 regions (the grid stores labels in 7 bits).
Expected<RenderFloor> buildRenderFloor(const FloorSpec& spec, const WorldOptions& options,
                                       const TextureLibrary& textures, Random& rng);

// The regions, doors and featureless zones of one floor of a Building: region 0 all corridors
// (boxes around every passage between corridor places), region 1 the elevator cab (open to the
// lobby through its door), then one region per room.
FloorSpec floorSpecOf(const Building& building, int floor, const BuildingOptions& building_options,
                      const WorldOptions& options);

// The elevator cab with its door closed: one region, no opening, at floor height 0 (the
// renderer shifts it to the cab's current height).
FloorSpec closedCabSpec(const Building& building);

// Every floor of a building plus the closed cab, painted from `textures`.
struct RenderWorld {
  std::vector<RenderFloor> floors;
  RenderFloor closed_cab;
};
Expected<RenderWorld> buildRenderWorld(const Building& building,
                                       const BuildingOptions& building_options,
                                       const WorldOptions& options, const TextureLibrary& textures,
                                       Random& rng);

}  // namespace evermap::sim
