// The renderer's inner loops: the portable and the AVX2 build give the same pixels, and the
// warp samples what it should.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/sim/random.h"
#include "core/sim/render_kernels.h"

namespace evermap::sim::kernels {
namespace {

struct WarpCase {
  std::vector<uint16_t> level;
  std::vector<int32_t> response;
  std::vector<int16_t> noise;
  WarpRow row;
};

WarpCase randomWarpCase(Random& rng, int level_w, int level_h, int width) {
  WarpCase c;
  c.level.resize(static_cast<size_t>(level_w) * level_h);
  for (uint16_t& p : c.level) p = static_cast<uint16_t>(rng.index(1024));
  c.response.resize(1024);
  for (int i = 0; i < 1024; ++i) c.response[static_cast<size_t>(i)] = static_cast<int32_t>(i * 255 / 1023);
  c.noise.resize(static_cast<size_t>(width));
  for (int16_t& n : c.noise) n = static_cast<int16_t>(rng.integer(-20, 20));
  c.row.level = c.level.data();
  c.row.level_w = level_w;
  c.row.max_u = static_cast<float>(level_w - 1) - 1e-3f;
  c.row.max_v = static_cast<float>(level_h - 1) - 1e-3f;
  c.row.response = c.response.data();
  return c;
}

TEST(RenderKernels, WarpAvx2MatchesPortableBitForBit) {
  if (!cpuHasAvx2()) GTEST_SKIP() << "this CPU has no AVX2";
  Random rng(3);
  for (const int width : {640, 752, 37, 8, 5}) {
    WarpCase c = randomWarpCase(rng, width + 24, 60, width);
    const int blocks = (width + c.row.block - 1) / c.row.block;
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<float> lu0(blocks), lv0(blocks), dlu(blocks), dlv(blocks);
      // Small rotations, plus rows running off the level image on every side (clamped).
      const double spread = trial < 10 ? 1.0 : 60.0;
      for (int b = 0; b < blocks; ++b) {
        lu0[b] = static_cast<float>(b * c.row.block + 12 + spread * (rng.uniform() - 0.5));
        lv0[b] = static_cast<float>(30 + spread * (rng.uniform() - 0.5));
        dlu[b] = static_cast<float>(1.0 + 0.01 * spread * (rng.uniform() - 0.5));
        dlv[b] = static_cast<float>(0.01 * spread * (rng.uniform() - 0.5));
      }
      std::vector<uint8_t> portable(width), avx2(width);
      warpRow(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(), c.noise.data(), width, portable.data());
      warpRowAvx2(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(), c.noise.data(), width, avx2.data());
      ASSERT_EQ(portable, avx2) << "width " << width << ", trial " << trial;
    }
  }
}

TEST(RenderKernels, WarpAtPixelCentresReadsTheLevelPixel) {
  Random rng(4);
  const int width = 40;
  WarpCase c = randomWarpCase(rng, 64, 10, width);
  // Output pixel u reads level pixel (u + 3, 5) exactly; no interpolation weight.
  std::vector<float> lu0 = {3.0f, 19.0f, 35.0f}, lv0 = {5.0f, 5.0f, 5.0f}, dlu = {1, 1, 1}, dlv = {0, 0, 0};
  std::vector<uint8_t> out(width);
  for (const bool avx2 : {false, true}) {
    if (avx2 && !cpuHasAvx2()) continue;
    (avx2 ? warpRowAvx2 : warpRow)(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(), c.noise.data(), width,
                                   out.data());
    for (int u = 0; u < width; ++u) {
      const int expected = std::clamp(c.response[c.level[5 * 64 + u + 3]] + c.noise[u], 0, 255);
      ASSERT_EQ(out[u], expected) << "u " << u << (avx2 ? " (AVX2)" : "");
    }
  }
}

}  // namespace
}  // namespace evermap::sim::kernels
