#pragma once
// The per-pixel inner loops of ImageRenderer (stereo_renderer.h), each in two builds: portable
// C++ and AVX2 (8 pixels at a time, gathers for the texel reads). Both do the same integer and
// IEEE float operations in the same order (multiply then add, never fused), so they give
// bit-identical images; the AVX2 one is chosen at run time when the CPU has it
// (cpuHasAvx2), and the build stays plain x86-64.

#include <cstdint>

namespace evermap::sim::kernels {

// True when the CPU running this has AVX2 (the AVX2 kernels may be called).
bool cpuHasAvx2();

// One output row of the warp from the level image into the real camera (render()'s step 2).
// The level pixel of output pixel u = b * block + k (0 <= k < block) is (lu0[b] + k dlu[b],
// lv0[b] + k dlv[b]) (float multiply then add): the homography is exact at block starts and
// linear in between. It is clamped to the level image, sampled bilinearly (8 fractional bits),
// mapped through `response` (light 0..1023 -> gray) and `noise` (gray levels per pixel) is
// added, clamped to 0..255.
struct WarpRow {
  const uint16_t* level = nullptr;  // the level image, row-major, level_w wide
  int level_w = 0;
  float max_u = 0, max_v = 0;       // largest level coordinates (keep x0 + 1, y0 + 1 inside)
  const int32_t* response = nullptr;  // 1024 entries
  int block = 16;                     // pixels per exact homography evaluation (multiple of 8)
};
void warpRow(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu, const float* dlv,
             const int16_t* noise, int width, uint8_t* out);
void warpRowAvx2(const WarpRow& w, const float* lu0, const float* lv0, const float* dlu, const float* dlv,
                 const int16_t* noise, int width, uint8_t* out);

}  // namespace evermap::sim::kernels
