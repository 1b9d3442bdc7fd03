#include "tools/sim/render_kernels.h"

#include <immintrin.h>

#include <algorithm>

namespace evermap::sim::kernels {
namespace {

// Bilinear interpolation with 8-bit weights, rounded: the same formula as Texture::sample.
// (The AVX2 kernels multiply a texel difference, |d| < 2^15, by a weight 0..255 with
// _mm256_madd_epi16: the low halves' product plus the high halves' (sign bits times 0) is
// exactly d * weight.)
inline int bilinear(int p00, int p01, int p10, int p11, int ax, int ay) {
  const int top = p00 * 256 + (p01 - p00) * ax;
  const int bottom = p10 * 256 + (p11 - p10) * ax;
  return (top * 256 + (bottom - top) * ay + (1 << 15)) >> 16;
}

inline uint8_t warpPixel(const WarpRow& w, float lu, float lv, int noise) {
  const float cu = lu < 0.0f ? 0.0f : (lu > w.max_u ? w.max_u : lu);
  const float cv = lv < 0.0f ? 0.0f : (lv > w.max_v ? w.max_v : lv);
  const int fu = static_cast<int>(cu * 256.0f), fv = static_cast<int>(cv * 256.0f);
  const uint16_t* p = w.level + static_cast<ptrdiff_t>(fv >> 8) * w.level_w + (fu >> 8);
  const int light = bilinear(p[0], p[1], p[w.level_w], p[w.level_w + 1], fu & 255, fv & 255);
  const int g = w.response[light] + noise;
  return static_cast<uint8_t>(g < 0 ? 0 : (g > 255 ? 255 : g));
}

inline int mipLevel(float lod) { return lod <= 0.0f ? 0 : static_cast<int>(lod + 0.25f); }

inline bool surfaceDrawn(const SurfaceRow& r, int u) {
  return r.down ? r.v >= r.col_limit[u] : r.v < r.col_limit[u];
}

inline uint16_t surfacePixel(const SurfaceRow& r, int u) {
  const float px = r.cx + r.t * r.col_dx[u], py = r.cy + r.t * r.col_dy[u];
  const uint8_t cell = r.floor->cellAt(px, py);
  const int value = r.texture_of_cell[cell]->sample(px * r.inv_texel, py * r.inv_texel,
                                                    mipLevel(r.lod_row + r.col_lod[u]));
  const int light = (value * r.gain_of_cell[cell]) >> 8;
  return static_cast<uint16_t>(light > 1023 ? 1023 : light);
}

inline float wallRow(const WallSpan& w, int v) {
  const float d = w.d_top + static_cast<float>(v - w.v_top) * w.step;
  return w.poster ? (w.offset_z - (w.height - d)) * w.scale_z : d * w.scale_z + w.offset_z;
}

// Bilinear interpolation in fixed point of four values per lane (p00, p01 of the upper row,
// p10, p11 of the lower) with 8-bit fractions ax (across) and ay (down); `half` = 1 << 15
// rounds the result back to the values' scale.
__attribute__((target("avx2"))) inline __m256i bilinearAvx2(__m256i p00, __m256i p01, __m256i p10,
                                                            __m256i p11, __m256i ax, __m256i ay,
                                                            __m256i half) {
  const __m256i top = _mm256_add_epi32(_mm256_slli_epi32(p00, 8),
                                       _mm256_madd_epi16(_mm256_sub_epi32(p01, p00), ax));
  const __m256i bottom = _mm256_add_epi32(_mm256_slli_epi32(p10, 8),
                                          _mm256_madd_epi16(_mm256_sub_epi32(p11, p10), ax));
  return _mm256_srai_epi32(
      _mm256_add_epi32(_mm256_add_epi32(_mm256_slli_epi32(top, 8),
                                        _mm256_mullo_epi32(_mm256_sub_epi32(bottom, top), ay)),
                       half),
      16);
}

// The 32-bit pixel pairs (q[o], q[o + 1]) for lane offsets o = 2 lane + odd in [0, 16).
__attribute__((target("avx2"))) inline __m256i pixelPairs(const uint16_t* q, __m256i lane,
                                                          __m256i odd) {
  const __m256i even_pairs = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q));
  const __m256i odd_pairs = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q + 1));
  return _mm256_blendv_epi8(_mm256_permutevar8x32_epi32(even_pairs, lane),
                            _mm256_permutevar8x32_epi32(odd_pairs, lane), odd);
}

}  // namespace

// The four texels of 8 bilinear samples (rows r0, r1 as offsets, columns x0, x1), each in the
// low byte of its lane. `adjacent` (no lane wraps: x1 = x0 + 1): one 32-bit gather per row
// reads both columns.
__attribute__((target("avx2"))) inline void gatherTexels(const int* texels, __m256i r0, __m256i r1,
                                                         __m256i x0, __m256i x1, bool adjacent,
                                                         __m256i low8, __m256i* p00, __m256i* p01,
                                                         __m256i* p10, __m256i* p11) {
  if (adjacent) {
    const __m256i g0 = _mm256_i32gather_epi32(texels, _mm256_add_epi32(r0, x0), 1);
    const __m256i g1 = _mm256_i32gather_epi32(texels, _mm256_add_epi32(r1, x0), 1);
    *p00 = _mm256_and_si256(g0, low8);
    *p01 = _mm256_and_si256(_mm256_srli_epi32(g0, 8), low8);
    *p10 = _mm256_and_si256(g1, low8);
    *p11 = _mm256_and_si256(_mm256_srli_epi32(g1, 8), low8);
  } else {
    *p00 = _mm256_and_si256(_mm256_i32gather_epi32(texels, _mm256_add_epi32(r0, x0), 1), low8);
    *p01 = _mm256_and_si256(_mm256_i32gather_epi32(texels, _mm256_add_epi32(r0, x1), 1), low8);
    *p10 = _mm256_and_si256(_mm256_i32gather_epi32(texels, _mm256_add_epi32(r1, x0), 1), low8);
    *p11 = _mm256_and_si256(_mm256_i32gather_epi32(texels, _mm256_add_epi32(r1, x1), 1), low8);
  }
}

// Texture::sample at one level for eight plane points (px, py), metres: bilinear between the
// level's texels, wrapping around its edges.
__attribute__((target("avx2"))) inline __m256i sampleLevelAvx2(const Texture::Level& L, __m256 px,
                                                               __m256 py, __m256 inv_texel) {
  const __m256 offset = _mm256_set1_ps(128.0f);
  const __m256i low8 = _mm256_set1_epi32(255), positive = _mm256_set1_epi32(1 << 28),
                one = _mm256_set1_epi32(1), half = _mm256_set1_epi32(1 << 15);
  const __m256 scale = _mm256_set1_ps(L.scale);
  const __m256i mask = _mm256_set1_epi32(L.mask);
  const __m256i fu =
      _mm256_add_epi32(_mm256_cvttps_epi32(_mm256_sub_ps(
                           _mm256_mul_ps(_mm256_mul_ps(px, inv_texel), scale), offset)),
                       positive);
  const __m256i fv =
      _mm256_add_epi32(_mm256_cvttps_epi32(_mm256_sub_ps(
                           _mm256_mul_ps(_mm256_mul_ps(py, inv_texel), scale), offset)),
                       positive);
  const __m256i x0 = _mm256_and_si256(_mm256_srai_epi32(fu, 8), mask),
                x1 = _mm256_and_si256(_mm256_add_epi32(x0, one), mask);
  const __m256i y0 = _mm256_and_si256(_mm256_srai_epi32(fv, 8), mask),
                y1 = _mm256_and_si256(_mm256_add_epi32(y0, one), mask);
  const __m128i shift = _mm_cvtsi32_si128(L.shift);
  const __m256i r0 = _mm256_sll_epi32(y0, shift), r1 = _mm256_sll_epi32(y1, shift);
  const auto* texels = reinterpret_cast<const int*>(L.texels);
  __m256i p00, p01, p10, p11;
  // No lane wraps around the texture's edge when no x0 is the last column.
  const bool adjacent =
      _mm256_testz_si256(_mm256_cmpeq_epi32(x0, mask), _mm256_cmpeq_epi32(x0, mask));
  gatherTexels(texels, r0, r1, x0, x1, adjacent, low8, &p00, &p01, &p10, &p11);
  const __m256i ax = _mm256_and_si256(fu, low8), ay = _mm256_and_si256(fv, low8);
  return bilinearAvx2(p00, p01, p10, p11, ax, ay, half);
}

void warpRow(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu,
             const float* dlv, const int16_t* noise, int width, uint8_t* out) {
  for (int b = 0, u = 0; u < width; ++b) {
    const int end = std::min(width, u + w.block);
    for (int k = 0; u < end; ++u, ++k) {
      const auto kf = static_cast<float>(k);
      out[u] = warpPixel(w, lu0[b] + kf * dlu[b], lv0[b] + kf * dlv[b], noise[u]);
    }
  }
}

__attribute__((target("avx2"))) void warpRowAvx2(const WarpRow& w, const float* lu0,
                                                 const float* lv0, const float* dlu,
                                                 const float* dlv, const int16_t* noise, int width,
                                                 uint8_t* out) {
  const __m256 zero = _mm256_setzero_ps(), max_u = _mm256_set1_ps(w.max_u),
               max_v = _mm256_set1_ps(w.max_v);
  const __m256 fixed = _mm256_set1_ps(256.0f);
  const __m256i lw = _mm256_set1_epi32(w.level_w), low8 = _mm256_set1_epi32(255),
                low16 = _mm256_set1_epi32(0xffff);
  const __m256i half = _mm256_set1_epi32(1 << 15),
                order = _mm256_setr_epi32(0, 4, 0, 4, 0, 4, 0, 4);
  const __m256i one = _mm256_set1_epi32(1), minus_one = _mm256_set1_epi32(-1),
                sixteen = _mm256_set1_epi32(16);
  const auto* level = reinterpret_cast<const int*>(w.level);
  const __m256 k0 = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  for (int b = 0, u = 0; u < width; ++b) {
    const int start = u, end = std::min(width, u + w.block);
    const __m256 a_u = _mm256_set1_ps(lu0[b]), a_v = _mm256_set1_ps(lv0[b]);
    const __m256 d_u = _mm256_set1_ps(dlu[b]), d_v = _mm256_set1_ps(dlv[b]);
    for (int k = 0; u + 8 <= end; u += 8, k += 8) {
      const __m256 kf = _mm256_add_ps(k0, _mm256_set1_ps(static_cast<float>(k)));
      const __m256 lu = _mm256_add_ps(a_u, _mm256_mul_ps(kf, d_u)),
                   lv = _mm256_add_ps(a_v, _mm256_mul_ps(kf, d_v));
      const __m256i fu =
          _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lu, zero), max_u), fixed));
      const __m256i fv =
          _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lv, zero), max_v), fixed));
      const __m256i x0 = _mm256_srli_epi32(fu, 8), y0 = _mm256_srli_epi32(fv, 8);
      // (g0, g1): the pixel pairs (x0, x0 + 1) of rows y0 and y0 + 1, as 32-bit lanes.
      __m256i g0, g1;
      const int first_x = _mm256_cvtsi256_si32(x0), first_y = _mm256_cvtsi256_si32(y0);
      const __m256i off = _mm256_sub_epi32(x0, _mm256_set1_epi32(first_x));
      const __m256i near = _mm256_and_si256(
          _mm256_cmpeq_epi32(y0, _mm256_set1_epi32(first_y)),
          _mm256_and_si256(_mm256_cmpgt_epi32(off, minus_one), _mm256_cmpgt_epi32(sixteen, off)));
      if (first_x + 17 <= w.level_w && _mm256_movemask_ps(_mm256_castsi256_ps(near)) == 0xff) {
        // A nearly level row: all eight within 16 pixels of one level row. Pairs at even
        // offsets are the 32-bit lanes of a load at first_x, odd ones of a load at first_x + 1.
        const uint16_t* p = w.level + static_cast<ptrdiff_t>(first_y) * w.level_w + first_x;
        const __m256i lane = _mm256_srli_epi32(off, 1);
        const __m256i odd = _mm256_cmpeq_epi32(_mm256_and_si256(off, one), one);
        g0 = pixelPairs(p, lane, odd);
        g1 = pixelPairs(p + w.level_w, lane, odd);
      } else {
        // One 32-bit gather reads two neighbouring 16-bit level pixels.
        const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(y0, lw), x0);
        g0 = _mm256_i32gather_epi32(level, idx, 2);
        g1 = _mm256_i32gather_epi32(level, _mm256_add_epi32(idx, lw), 2);
      }
      const __m256i ax = _mm256_and_si256(fu, low8), ay = _mm256_and_si256(fv, low8);
      const __m256i p00 = _mm256_and_si256(g0, low16), p01 = _mm256_srli_epi32(g0, 16);
      const __m256i p10 = _mm256_and_si256(g1, low16), p11 = _mm256_srli_epi32(g1, 16);
      const __m256i light = bilinearAvx2(p00, p01, p10, p11, ax, ay, half);
      const __m256i gray = _mm256_add_epi32(
          _mm256_i32gather_epi32(w.response, light, 4),
          _mm256_cvtepi16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(noise + u))));
      // Saturating packs clamp to 0..255; the permute gathers the two lanes' bytes.
      const __m256i bytes =
          _mm256_packus_epi16(_mm256_packus_epi32(gray, gray), _mm256_setzero_si256());
      const __m256i both = _mm256_permutevar8x32_epi32(bytes, order);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(out + u), _mm256_castsi256_si128(both));
    }
    for (; u < end; ++u) {  // a block that is not a multiple of 8 wide (the row's end)
      const auto kf = static_cast<float>(u - start);
      out[u] = warpPixel(w, lu0[b] + kf * dlu[b], lv0[b] + kf * dlv[b], noise[u]);
    }
  }
}

void surfaceRow(const SurfaceRow& r, int width, uint16_t* out) {
  for (int u = 0; u < width; ++u) {
    if (surfaceDrawn(r, u)) out[u] = surfacePixel(r, u);
  }
}

__attribute__((target("avx2"))) void surfaceRowAvx2(const SurfaceRow& r, int width, uint16_t* out) {
  const RenderFloor& f = *r.floor;
  const __m256 t = _mm256_set1_ps(r.t), cx = _mm256_set1_ps(r.cx), cy = _mm256_set1_ps(r.cy);
  const __m256 gx0 = _mm256_set1_ps(f.grid_x0), gy0 = _mm256_set1_ps(f.grid_y0),
               inv_cell = _mm256_set1_ps(f.inv_cell);
  const __m256 inv_texel = _mm256_set1_ps(r.inv_texel), lod_row = _mm256_set1_ps(r.lod_row);
  const __m256 quarter = _mm256_set1_ps(0.25f), zero_ps = _mm256_setzero_ps();
  const __m256i zero = _mm256_setzero_si256(), gw = _mm256_set1_epi32(f.grid_w);
  const __m256i max_i = _mm256_set1_epi32(f.grid_w - 1), max_j = _mm256_set1_epi32(f.grid_h - 1);
  const __m256i low8 = _mm256_set1_epi32(255), max_light = _mm256_set1_epi32(1023);
  // Drawn: down v >= limit, i.e. v + 1 > limit; up: limit > v.
  const __m256i v_cmp = _mm256_set1_epi32(r.down ? r.v + 1 : r.v);
  const auto* grid = reinterpret_cast<const int*>(f.grid.data());
  int u = 0;
  for (; u + 8 <= width; u += 8) {
    const __m256i limit = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.col_limit + u));
    const __m256i drawn =
        r.down ? _mm256_cmpgt_epi32(v_cmp, limit) : _mm256_cmpgt_epi32(limit, v_cmp);
    const int drawn_bits = _mm256_movemask_ps(_mm256_castsi256_ps(drawn));
    if (drawn_bits == 0) continue;
    const __m256 px = _mm256_add_ps(cx, _mm256_mul_ps(t, _mm256_loadu_ps(r.col_dx + u)));
    const __m256 py = _mm256_add_ps(cy, _mm256_mul_ps(t, _mm256_loadu_ps(r.col_dy + u)));
    // RenderFloor::cellAt, clamped to the grid.
    __m256i i = _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_sub_ps(px, gx0), inv_cell));
    __m256i j = _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_sub_ps(py, gy0), inv_cell));
    i = _mm256_min_epi32(_mm256_max_epi32(i, zero), max_i);
    j = _mm256_min_epi32(_mm256_max_epi32(j, zero), max_j);
    const __m256i cell = _mm256_and_si256(
        _mm256_i32gather_epi32(grid, _mm256_add_epi32(_mm256_mullo_epi32(j, gw), i), 1), low8);
    const __m256 lod = _mm256_add_ps(lod_row, _mm256_loadu_ps(r.col_lod + u));
    const __m256i level =
        _mm256_andnot_si256(_mm256_castps_si256(_mm256_cmp_ps(lod, zero_ps, _CMP_LE_OQ)),
                            _mm256_cvttps_epi32(_mm256_add_ps(lod, quarter)));
    alignas(32) int cells[8], levels[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(cells), cell);
    _mm256_store_si256(reinterpret_cast<__m256i*>(levels), level);
    const int first = __builtin_ctz(static_cast<unsigned>(drawn_bits));
    const __m256i same =
        _mm256_and_si256(_mm256_cmpeq_epi32(cell, _mm256_set1_epi32(cells[first])),
                         _mm256_cmpeq_epi32(level, _mm256_set1_epi32(levels[first])));
    if ((_mm256_movemask_ps(_mm256_castsi256_ps(same)) & drawn_bits) != drawn_bits) {
      // The drawn pixels span two cells or mip levels: one by one.
      for (int k = 0; k < 8; ++k) {
        if (drawn_bits >> k & 1) out[u + k] = surfacePixel(r, u + k);
      }
      continue;
    }
    // Texture::sample at one level for all eight.
    const Texture::Level& L = r.texture_of_cell[cells[first]]->levelView(levels[first]);
    const __m256i value = sampleLevelAvx2(L, px, py, inv_texel);
    const __m256i light = _mm256_min_epi32(
        _mm256_srai_epi32(
            _mm256_mullo_epi32(value, _mm256_set1_epi32(r.gain_of_cell[cells[first]])), 8),
        max_light);
    // Eight 16-bit results (and drawn masks) in the low half, in order.
    const __m128i fresh =
        _mm256_castsi256_si128(_mm256_permute4x64_epi64(_mm256_packus_epi32(light, light), 0x08));
    const __m128i keep =
        _mm256_castsi256_si128(_mm256_permute4x64_epi64(_mm256_packs_epi32(drawn, drawn), 0x08));
    auto* dst = reinterpret_cast<__m128i*>(out + u);
    _mm_storeu_si128(dst, _mm_blendv_epi8(_mm_loadu_si128(dst), fresh, keep));
  }
  for (; u < width; ++u) {
    if (surfaceDrawn(r, u)) out[u] = surfacePixel(r, u);
  }
}

void wallSpan(const WallSpan& w, int v0, int v1, uint16_t* out, int stride) {
  for (int v = v0; v < v1; ++v) {
    const int light = ((*w.column)(wallRow(w, v)) * w.gain) >> 8;
    out[static_cast<ptrdiff_t>(v) * stride] = static_cast<uint16_t>(light > 1023 ? 1023 : light);
  }
}

__attribute__((target("avx2"))) void wallSpanAvx2(const WallSpan& w, int v0, int v1, uint16_t* out,
                                                  int stride) {
  const Texture::Column& c = *w.column;
  const Texture::Level& L = c.level();
  const __m256 d_top = _mm256_set1_ps(w.d_top), step = _mm256_set1_ps(w.step),
               scale_z = _mm256_set1_ps(w.scale_z);
  const __m256 offset_z = _mm256_set1_ps(w.offset_z), height = _mm256_set1_ps(w.height);
  const __m256 scale = _mm256_set1_ps(L.scale), offset = _mm256_set1_ps(128.0f);
  const __m256i k0 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), mask = _mm256_set1_epi32(L.mask);
  const __m256i x0 = _mm256_set1_epi32(c.x0()), x1 = _mm256_set1_epi32(c.x1()),
                ax = _mm256_set1_epi32(c.ax());
  const __m256i low8 = _mm256_set1_epi32(255), positive = _mm256_set1_epi32(1 << 28),
                one = _mm256_set1_epi32(1);
  const __m256i half = _mm256_set1_epi32(1 << 15), max_light = _mm256_set1_epi32(1023),
                gain = _mm256_set1_epi32(w.gain);
  const __m128i shift = _mm_cvtsi32_si128(L.shift);
  const auto* texels = reinterpret_cast<const int*>(L.texels);
  // Unless the column wraps around the texture's edge, one 32-bit gather reads both texels.
  const bool adjacent = c.x1() == c.x0() + 1;
  int v = v0;
  for (; v + 8 <= v1; v += 8) {
    const __m256 k = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(v - w.v_top), k0));
    const __m256 d = _mm256_add_ps(d_top, _mm256_mul_ps(k, step));
    const __m256 row =
        w.poster ? _mm256_mul_ps(_mm256_sub_ps(offset_z, _mm256_sub_ps(height, d)), scale_z)
                 : _mm256_add_ps(_mm256_mul_ps(d, scale_z), offset_z);
    const __m256i fv = _mm256_add_epi32(
        _mm256_cvttps_epi32(_mm256_sub_ps(_mm256_mul_ps(row, scale), offset)), positive);
    const __m256i y0 = _mm256_and_si256(_mm256_srai_epi32(fv, 8), mask),
                  y1 = _mm256_and_si256(_mm256_add_epi32(y0, one), mask);
    const __m256i r0 = _mm256_sll_epi32(y0, shift), r1 = _mm256_sll_epi32(y1, shift);
    __m256i p00, p01, p10, p11;
    gatherTexels(texels, r0, r1, x0, x1, adjacent, low8, &p00, &p01, &p10, &p11);
    const __m256i ay = _mm256_and_si256(fv, low8);
    const __m256i value = bilinearAvx2(p00, p01, p10, p11, ax, ay, half);
    const __m256i light =
        _mm256_min_epi32(_mm256_srai_epi32(_mm256_mullo_epi32(value, gain), 8), max_light);
    alignas(32) int32_t lights[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(lights), light);
    uint16_t* o = out + static_cast<ptrdiff_t>(v) * stride;
    for (int i = 0; i < 8; ++i, o += stride) *o = static_cast<uint16_t>(lights[i]);
  }
  wallSpan(w, v, v1, out, stride);
}

}  // namespace evermap::sim::kernels
