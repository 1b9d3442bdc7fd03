#pragma once
// The per-pixel inner loops of ImageRenderer (stereo_renderer.h), each in two builds: portable
// C++ and AVX2 (8 pixels at a time, gathers for the texel reads). Both do the same integer and
// IEEE float operations in the same order (multiply then add, never fused), so they give
// bit-identical images; the AVX2 one is chosen at run time when the CPU has it
// (core::cpuHasAvx2, core/common/cpu.h), and the build stays plain x86-64.

#include <cstdint>

#include "core/common/cpu.h"
#include "tools/sim/render_world.h"
#include "tools/sim/textures.h"

namespace evermap::sim::kernels {

// One output row of the warp from the level image into the real camera (render()'s step 2).
// The level pixel of output pixel u = b * block + k (0 <= k < block) is (lu0[b] + k dlu[b],
// lv0[b] + k dlv[b]) (float multiply then add): the homography is exact at block starts and
// linear in between. It is clamped to the level image, sampled bilinearly (8 fractional bits),
// mapped through `response` (light 0..1023 -> gray) and `noise` (gray levels per pixel) is
// added, clamped to 0..255.
struct WarpRow {
  const uint16_t* level = nullptr;  // the level image, row-major, level_w wide
  int level_w = 0;
  float max_u = 0, max_v = 0;         // largest level coordinates (keep x0 + 1, y0 + 1 inside)
  const int32_t* response = nullptr;  // 1024 entries
  int block = 16;                     // pixels per exact homography evaluation (multiple of 8)
};
void warpRow(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu,
             const float* dlv, const int16_t* noise, int width, uint8_t* out);
void warpRowAvx2(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu,
                 const float* dlv, const int16_t* noise, int width, uint8_t* out);

// One row v of the floor (v below the horizon) or the ceiling seen by the level camera
// (renderLevel's floor pass). Pixel u shows the floor point c + t (dx[u], dy[u]) unless a wall
// covers it; its texture and brightness come from the grid cell of that point, its mip level
// from lod_row + col_lod[u]. Writes light = texel * gain / 256 (at most 1023).
struct SurfaceRow {
  int v = 0;
  bool down = true;               // floor (true) or ceiling
  float t = 0;                    // horizontal distance of the row's points, metres
  float inv_texel = 1;            // texels per metre
  float lod_row = 0;              // the row's part of the mip level
  float cx = 0, cy = 0;           // camera centre, world x y
  const float* col_dx = nullptr;  // per column: horizontal ray direction, world x y
  const float* col_dy = nullptr;
  const float* col_lod = nullptr;  // per column: the column's part of the mip level
  const int* col_limit = nullptr;  // per column: first floor row (down), else last ceiling row + 1
  const RenderFloor* floor = nullptr;
  const Texture* const* texture_of_cell = nullptr;  // per grid cell value (256)
  const int* gain_of_cell = nullptr;                // per grid cell value, brightness * 256
};
void surfaceRow(const SurfaceRow& r, int width, uint16_t* out);
void surfaceRowAvx2(const SurfaceRow& r, int width, uint16_t* out);

// Rows [v0, v1) of one column of the level image showing a wall (or a poster on it): a level
// camera sees one texture column there (renderLevel's wall pass). Row v is at depth
// d(v) = d_top + (v - v_top) step below the ceiling (float multiply then add), its texture row
// is d(v) * scale_z + offset_z on a wall, (offset_z - (height - d(v))) * scale_z on a poster.
// Writes light = texel * gain / 256 (at most 1023) to out[v * stride].
struct WallSpan {
  const Texture::Column* column = nullptr;
  int gain = 256;
  int v_top = 0;
  float d_top = 0, step = 0;  // metres below the ceiling at v_top, and per row
  bool poster = false;
  float scale_z = 1, offset_z = 0, height = 0;
};
void wallSpan(const WallSpan& w, int v0, int v1, uint16_t* out, int stride);
void wallSpanAvx2(const WallSpan& w, int v0, int v1, uint16_t* out, int stride);

}  // namespace evermap::sim::kernels
