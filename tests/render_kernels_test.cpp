// The renderer's inner loops: the portable and the AVX2 build give the same pixels, and the
// warp samples what it should.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tools/sim/random.h"
#include "tools/sim/render_kernels.h"
#include "tools/sim/render_world.h"
#include "tools/sim/textures.h"

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
  for (int i = 0; i < 1024; ++i)
    c.response[static_cast<size_t>(i)] = static_cast<int32_t>(i * 255 / 1023);
  c.noise.resize(static_cast<size_t>(width));
  for (int16_t& n : c.noise) n = static_cast<int16_t>(rng.integer(-20, 20));
  c.row.level = c.level.data();
  c.row.level_w = level_w;
  c.row.max_u = static_cast<float>(level_w - 1) - 1e-3f;
  c.row.max_v = static_cast<float>(level_h - 1) - 1e-3f;
  c.row.response = c.response.data();
  return c;
}

// A texture library of one variant per texture, drawn from rng.
Expected<TextureLibrary> oneVariantLibrary(Random& rng) {
  TextureOptions to;
  to.variants = 1;
  return makeTextureLibrary(to, {}, rng);
}

TEST(RenderKernels, WarpAvx2MatchesPortableBitForBit) {
  if (!core::cpuHasAvx2()) GTEST_SKIP() << "this CPU has no AVX2";
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
      warpRow(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(), c.noise.data(), width,
              portable.data());
      warpRowAvx2(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(), c.noise.data(), width,
                  avx2.data());
      ASSERT_EQ(portable, avx2) << "width " << width << ", trial " << trial;
    }
  }
}

TEST(RenderKernels, WarpAtPixelCentresReadsTheLevelPixel) {
  Random rng(4);
  const int width = 40;
  WarpCase c = randomWarpCase(rng, 64, 10, width);
  // Output pixel u reads level pixel (u + 3, 5) exactly; no interpolation weight.
  std::vector<float> lu0 = {3.0f, 19.0f, 35.0f}, lv0 = {5.0f, 5.0f, 5.0f}, dlu = {1, 1, 1},
                     dlv = {0, 0, 0};
  std::vector<uint8_t> out(width);
  for (const bool avx2 : {false, true}) {
    if (avx2 && !core::cpuHasAvx2()) continue;
    (avx2 ? warpRowAvx2 : warpRow)(c.row, lu0.data(), lv0.data(), dlu.data(), dlv.data(),
                                   c.noise.data(), width, out.data());
    for (int u = 0; u < width; ++u) {
      const int expected = std::clamp(c.response[c.level[5 * 64 + u + 3]] + c.noise[u], 0, 255);
      ASSERT_EQ(out[u], expected) << "u " << u << (avx2 ? " (AVX2)" : "");
    }
  }
}

// Three rooms side by side (the middle one dark) and a featureless zone over the third.
RenderFloor threeRooms(const TextureLibrary& lib) {
  FloorSpec spec;
  for (int k = 0; k < 3; ++k) {
    Region r;
    r.boxes.push_back(Box{Vec2(4.0 * k, 0.0), Vec2(4.0 * k + 3.9, 6.0)});
    r.dark = k == 1;
    spec.regions.push_back(r);
  }
  spec.blank_centres.push_back(Vec2(10.0, 3.0));
  WorldOptions o;
  o.blank_radius_m = 1.5;
  Random rng(7);
  auto floor = buildRenderFloor(spec, o, lib, rng);
  EXPECT_TRUE(floor) << floor.error().message;
  return std::move(*floor);
}

TEST(RenderKernels, SurfaceRowAvx2MatchesPortableBitForBit) {
  if (!core::cpuHasAvx2()) GTEST_SKIP() << "this CPU has no AVX2";
  Random rng(5);
  auto lib = oneVariantLibrary(rng);
  ASSERT_TRUE(lib) << lib.error().message;
  const RenderFloor floor = threeRooms(*lib);
  std::vector<const Texture*> texture_of_cell(256);
  std::vector<int> gain_of_cell(256);
  for (int cell = 0; cell < 256; ++cell) {
    texture_of_cell[static_cast<size_t>(cell)] =
        &lib->textures[static_cast<size_t>(cell % lib->textures.size())];
    gain_of_cell[static_cast<size_t>(cell)] =
        200 + 450 * (cell % 4);  // up to 1550: bright texels clip at 1023
  }
  for (const int width : {664, 29}) {
    std::vector<float> dx(width), dy(width), lod(width);
    std::vector<int> limit(width);
    for (int trial = 0; trial < 200; ++trial) {
      // A camera anywhere over (and around) the floor looking along a random heading; rows
      // from under the feet to far away cross cells, regions and mip levels.
      const double heading = 2.0 * 3.14159265 * rng.uniform(), fov = rng.uniform(0.2, 1.5);
      for (int u = 0; u < width; ++u) {
        const double x = fov * (u - 0.5 * width) / width;
        dx[u] = static_cast<float>(std::cos(heading) + x * std::sin(heading));
        dy[u] = static_cast<float>(std::sin(heading) - x * std::cos(heading));
        lod[u] = static_cast<float>(0.75 * std::log2(1.0 + x * x));
        limit[u] = static_cast<int>(rng.index(40));
      }
      SurfaceRow row;
      row.v = 20;
      row.down = trial % 2 == 0;
      row.t = static_cast<float>(std::exp(rng.uniform(-1.0, 3.0)));
      row.inv_texel = 80.0f;
      row.lod_row = static_cast<float>(rng.uniform(-2.0, 6.0));
      row.cx = static_cast<float>(rng.uniform(-2.0, 14.0));
      row.cy = static_cast<float>(rng.uniform(-2.0, 8.0));
      row.col_dx = dx.data();
      row.col_dy = dy.data();
      row.col_lod = lod.data();
      row.col_limit = limit.data();
      row.floor = &floor;
      row.texture_of_cell = texture_of_cell.data();
      row.gain_of_cell = gain_of_cell.data();
      std::vector<uint16_t> portable(width);
      for (uint16_t& p : portable)
        p = static_cast<uint16_t>(rng.index(1024));  // what the walls drew
      std::vector<uint16_t> avx2 = portable;
      surfaceRow(row, width, portable.data());
      surfaceRowAvx2(row, width, avx2.data());
      ASSERT_EQ(portable, avx2) << "width " << width << ", trial " << trial;
    }
  }
}

TEST(RenderKernels, WallSpanAvx2MatchesPortableBitForBit) {
  if (!core::cpuHasAvx2()) GTEST_SKIP() << "this CPU has no AVX2";
  Random rng(6);
  auto lib = oneVariantLibrary(rng);
  ASSERT_TRUE(lib) << lib.error().message;
  const int stride = 7, rows = 300;
  for (int trial = 0; trial < 300; ++trial) {
    const Texture& texture =
        lib->textures[static_cast<size_t>(rng.index(static_cast<int64_t>(lib->textures.size())))];
    // Every fifth column sits on the texture's last texel column (its neighbour wraps to 0).
    const float tu = trial % 5 == 0 ? static_cast<float>(texture.size()) - 0.2f
                                    : static_cast<float>(rng.uniform(-500.0, 500.0));
    const Texture::Column column(texture, tu, static_cast<int>(rng.index(5)) - 1);
    WallSpan span;
    span.column = &column;
    span.gain = static_cast<int>(rng.integer(10, 1500));
    span.v_top = static_cast<int>(rng.index(40));
    span.d_top = static_cast<float>(rng.uniform(0.0, 1.0));
    span.step = static_cast<float>(std::exp(rng.uniform(-8.0, -2.0)));
    span.poster = trial % 3 == 0;
    span.scale_z = static_cast<float>(rng.uniform(20.0, 300.0));
    span.offset_z = static_cast<float>(rng.uniform(-100.0, 100.0));
    span.height = 2.8f;
    const int v0 = span.v_top + static_cast<int>(rng.index(30)),
              v1 = v0 + static_cast<int>(rng.index(rows - 70));
    std::vector<uint16_t> portable(static_cast<size_t>(rows) * stride);
    for (uint16_t& p : portable) p = static_cast<uint16_t>(rng.index(1024));
    std::vector<uint16_t> avx2 = portable;
    wallSpan(span, v0, v1, portable.data() + 3, stride);
    wallSpanAvx2(span, v0, v1, avx2.data() + 3, stride);
    ASSERT_EQ(portable, avx2) << "trial " << trial;
  }
}

TEST(RenderKernels, WallSpanSamplesTheTextureColumn) {
  Random rng(8);
  auto lib = oneVariantLibrary(rng);
  ASSERT_TRUE(lib) << lib.error().message;
  const Texture& texture = lib->textures[0];
  const Texture::Column column(texture, 17.3f, 1);
  WallSpan span;
  span.column = &column;
  span.v_top = 5;
  span.d_top = 0.25f;
  span.step = 0.004f;
  span.scale_z = 100.0f;
  span.offset_z = 3.0f;
  std::vector<uint16_t> out(100, 0);
  for (const bool avx2 : {false, true}) {
    if (avx2 && !core::cpuHasAvx2()) continue;
    (avx2 ? wallSpanAvx2 : wallSpan)(span, 10, 90, out.data(), 1);
    for (int v = 10; v < 90; ++v) {
      const float d = 0.25f + static_cast<float>(v - 5) * 0.004f;
      ASSERT_EQ(out[v], texture.sample(17.3f, d * 100.0f + 3.0f, 1))
          << "v " << v << (avx2 ? " (AVX2)" : "");
    }
  }
}

}  // namespace
}  // namespace evermap::sim::kernels
