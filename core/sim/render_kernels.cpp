#include "core/sim/render_kernels.h"

#include <immintrin.h>

#include <algorithm>

namespace evermap::sim::kernels {
namespace {

// Bilinear interpolation with 8-bit weights, rounded: the same formula as Texture::sample.
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

}  // namespace

bool cpuHasAvx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}

void warpRow(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu, const float* dlv,
             const int16_t* noise, int width, uint8_t* out) {
  for (int b = 0, u = 0; u < width; ++b) {
    const int end = std::min(width, u + w.block);
    for (int k = 0; u < end; ++u, ++k) {
      const auto kf = static_cast<float>(k);
      out[u] = warpPixel(w, lu0[b] + kf * dlu[b], lv0[b] + kf * dlv[b], noise[u]);
    }
  }
}

__attribute__((target("avx2"))) void warpRowAvx2(const WarpRow& w, const float* lu0, const float* lv0,
                                                 const float* dlu, const float* dlv, const int16_t* noise,
                                                 int width, uint8_t* out) {
  const __m256 zero = _mm256_setzero_ps(), max_u = _mm256_set1_ps(w.max_u), max_v = _mm256_set1_ps(w.max_v);
  const __m256 fixed = _mm256_set1_ps(256.0f);
  const __m256i lw = _mm256_set1_epi32(w.level_w), low8 = _mm256_set1_epi32(255), low16 = _mm256_set1_epi32(0xffff);
  const __m256i half = _mm256_set1_epi32(1 << 15), order = _mm256_setr_epi32(0, 4, 0, 4, 0, 4, 0, 4);
  const auto* level = reinterpret_cast<const int*>(w.level);
  const __m256 k0 = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  for (int b = 0, u = 0; u < width; ++b) {
    const int start = u, end = std::min(width, u + w.block);
    const __m256 a_u = _mm256_set1_ps(lu0[b]), a_v = _mm256_set1_ps(lv0[b]);
    const __m256 d_u = _mm256_set1_ps(dlu[b]), d_v = _mm256_set1_ps(dlv[b]);
    for (int k = 0; u + 8 <= end; u += 8, k += 8) {
      const __m256 kf = _mm256_add_ps(k0, _mm256_set1_ps(static_cast<float>(k)));
      const __m256 lu = _mm256_add_ps(a_u, _mm256_mul_ps(kf, d_u)), lv = _mm256_add_ps(a_v, _mm256_mul_ps(kf, d_v));
      const __m256i fu = _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lu, zero), max_u), fixed));
      const __m256i fv = _mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lv, zero), max_v), fixed));
      const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_srli_epi32(fv, 8), lw), _mm256_srli_epi32(fu, 8));
      // One 32-bit gather reads two neighbouring 16-bit level pixels.
      const __m256i g0 = _mm256_i32gather_epi32(level, idx, 2);
      const __m256i g1 = _mm256_i32gather_epi32(level, _mm256_add_epi32(idx, lw), 2);
      const __m256i ax = _mm256_and_si256(fu, low8), ay = _mm256_and_si256(fv, low8);
      const __m256i p00 = _mm256_and_si256(g0, low16), p01 = _mm256_srli_epi32(g0, 16);
      const __m256i p10 = _mm256_and_si256(g1, low16), p11 = _mm256_srli_epi32(g1, 16);
      const __m256i top = _mm256_add_epi32(_mm256_slli_epi32(p00, 8), _mm256_mullo_epi32(_mm256_sub_epi32(p01, p00), ax));
      const __m256i bottom = _mm256_add_epi32(_mm256_slli_epi32(p10, 8), _mm256_mullo_epi32(_mm256_sub_epi32(p11, p10), ax));
      const __m256i light = _mm256_srai_epi32(
          _mm256_add_epi32(_mm256_add_epi32(_mm256_slli_epi32(top, 8), _mm256_mullo_epi32(_mm256_sub_epi32(bottom, top), ay)), half), 16);
      const __m256i gray = _mm256_add_epi32(_mm256_i32gather_epi32(w.response, light, 4),
                                            _mm256_cvtepi16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(noise + u))));
      // Saturating packs clamp to 0..255; the permute gathers the two lanes' bytes.
      const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(gray, gray), _mm256_setzero_si256());
      const __m256i both = _mm256_permutevar8x32_epi32(bytes, order);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(out + u), _mm256_castsi256_si128(both));
    }
    for (; u < end; ++u) {  // a block that is not a multiple of 8 wide (the row's end)
      const auto kf = static_cast<float>(u - start);
      out[u] = warpPixel(w, lu0[b] + kf * dlu[b], lv0[b] + kf * dlv[b], noise[u]);
    }
  }
}

}  // namespace evermap::sim::kernels
