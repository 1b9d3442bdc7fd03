#include "tools/sim/stereo_renderer.h"

#include "tools/sim/render_kernels.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace evermap::sim {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kLevelMargin = 12;  // pixels around the level image (tilt up to ~1.5 degrees)
constexpr int kNoiseTable = 1 << 16;

inline int mipLevel(float lod) { return lod <= 0.0f ? 0 : static_cast<int>(lod + 0.25f); }

}  // namespace

Status PinholeCamera::validate() const {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    return makeError("width: image size must be in [16, 8192], got ", width, "x", height);
  }
  if (!(fx > 0.0 && fy > 0.0 && std::isfinite(fx) && std::isfinite(fy)))
    return makeError("fx: focal lengths must be > 0");
  if (!(cx >= 0.0 && cx < width && cy >= 0.0 && cy < height)) {
    return makeError("cx: the principal point must lie inside the image");
  }
  return Ok{};
}

Status Lighting::validate() const {
  if (!(gain > 0.0 && gain < 10.0)) return makeError("gain: must be in (0, 10)");
  if (!(offset_gray > -255.0 && offset_gray < 255.0))
    return makeError("offset_gray: must be in (-255, 255)");
  if (!(gamma > 0.1 && gamma < 10.0)) return makeError("gamma: must be in (0.1, 10)");
  return Ok{};
}

ImageRenderer::ImageRenderer(const TextureLibrary& textures, const PinholeCamera& camera,
                             double noise_sigma_gray, uint64_t noise_seed)
    : textures_(textures), camera_(camera), rng_(noise_seed), avx2_(core::cpuHasAvx2()) {
  noise_.resize(kNoiseTable + static_cast<size_t>(camera.width));
  for (int16_t& n : noise_) {
    n = static_cast<int16_t>(
        std::lround(noise_sigma_gray > 0.0 ? noise_sigma_gray * rng_.normal() : 0.0));
  }
  setLighting(Lighting{});
  level_w_ = camera.width + 2 * kLevelMargin;
  level_h_ = camera.height + 2 * kLevelMargin;
  level_.resize(static_cast<size_t>(level_w_) * level_h_);
  depth_.resize(static_cast<size_t>(level_w_));
  nearest_.resize(static_cast<size_t>(level_w_));
}

void ImageRenderer::setLighting(const Lighting& l) {
  response_.resize(1024);
  for (int i = 0; i < 1024; ++i) {
    const double x = i / 255.0;
    const double y = 255.0 * l.gain * std::pow(x, l.gamma) + l.offset_gray;
    response_[static_cast<size_t>(i)] = static_cast<int32_t>(std::clamp(std::lround(y), 0L, 255L));
  }
}

// The level camera of one render: centre, heading, and the level image's intrinsics.
struct ImageRenderer::LevelView {
  core::Vec3 c;
  core::Vec2 hf, hl;  // heading (forward) and its left, horizontal
  double fx = 0.0, fy = 0.0, cxl = 0.0, cyl = 0.0;
  double below = 0.0, above = 0.0;  // camera height over the floor, under the ceiling
  // Column u looks along dxy(u) = hf - x(u) hl, x(u) = (u - cx) / fx (camera x is right).
  double xOf(int u) const { return (u - cxl) / fx; }
};

void ImageRenderer::renderLevel(const RenderFloor& floor, double z_shift, const core::Vec3& c,
                                const core::Vec2& hf, std::span<const Occluder> occluders,
                                bool with_depth) {
  LevelView view;
  view.c = c;
  view.hf = hf;
  view.hl = core::Vec2(-hf.y(), hf.x());
  view.fx = camera_.fx;
  view.fy = camera_.fy;
  view.cxl = camera_.cx + kLevelMargin;
  view.cyl = camera_.cy + kLevelMargin;
  const double fz = floor.floor_z + z_shift, cz = floor.ceiling_z + z_shift;
  view.below = c.z() - fz;
  view.above = cz - c.z();
  nearestWalls(floor, view);
  surfaceDepths(view);
  for (int u = 0; u < level_w_; ++u) drawWallColumn(floor, view, u);
  drawSurfaces(floor, view);
  if (with_depth) fillLevelDepth();
  drawOccluders(view, occluders, with_depth);
}

void ImageRenderer::nearestWalls(const RenderFloor& floor, const LevelView& view) {
  const int W = level_w_;
  const core::Vec3& c = view.c;
  const core::Vec2 &hf = view.hf, &hl = view.hl;
  const double fx = view.fx, cxl = view.cxl;
  // 1-D depth buffer: the nearest facing wall per column (forward distance).
  std::fill(depth_.begin(), depth_.end(), kInf);
  std::fill(nearest_.begin(), nearest_.end(), -1);
  for (size_t i = 0; i < floor.walls.size(); ++i) {
    const Wall& w = floor.walls[i];
    const double ahead = (c.x() - w.p0x) * w.nx + (c.y() - w.p0y) * w.ny;
    if (ahead <= 1e-4) continue;  // behind the wall's face
    double q[2][2];               // end points: forward, left
    for (int e = 0; e < 2; ++e) {
      const double px = w.p0x + e * w.length * w.ex - c.x(),
                   py = w.p0y + e * w.length * w.ey - c.y();
      q[e][0] = px * hf.x() + py * hf.y();
      q[e][1] = px * hl.x() + py * hl.y();
    }
    constexpr double kNear = 1e-3;
    if (q[0][0] < kNear && q[1][0] < kNear) continue;
    for (int e = 0; e < 2; ++e) {  // clip to the half plane ahead
      if (q[e][0] < kNear) {
        const int o = 1 - e;
        const double t = (kNear - q[o][0]) / (q[e][0] - q[o][0]);
        q[e][1] = q[o][1] + t * (q[e][1] - q[o][1]);
        q[e][0] = kNear;
      }
    }
    const double ua = cxl - fx * q[0][1] / q[0][0], ub = cxl - fx * q[1][1] / q[1][0];
    const int u0 = std::max(0, static_cast<int>(std::ceil(std::min(ua, ub) - 0.01)));
    const int u1 = std::min(W - 1, static_cast<int>(std::floor(std::max(ua, ub) + 0.01)));
    const double nf = w.nx * hf.x() + w.ny * hf.y(), nl = w.nx * hl.x() + w.ny * hl.y();
    for (int u = u0; u <= u1; ++u) {
      const double den = nf - view.xOf(u) * nl;
      if (den >= -1e-9) continue;
      const auto t = static_cast<float>(-ahead / den);
      if (t < depth_[static_cast<size_t>(u)]) {
        depth_[static_cast<size_t>(u)] = t;
        nearest_[static_cast<size_t>(u)] = static_cast<int>(i);
      }
    }
  }
}

void ImageRenderer::surfaceDepths(const LevelView& view) {
  const int W = level_w_, H = level_h_;
  const double fy = view.fy, cyl = view.cyl;
  // Per row: depth of floor (below the horizon) or ceiling (above) and its mip level part.
  row_t_.resize(static_cast<size_t>(H));
  row_lod_.resize(static_cast<size_t>(H));
  col_lod_.resize(static_cast<size_t>(W));
  for (int v = 0; v < H; ++v) {
    const double dz = std::max(std::abs(v - cyl) / fy, 1e-4);
    const double t = std::min((v > cyl ? view.below : view.above) / dz, 1e4);
    row_t_[static_cast<size_t>(v)] = static_cast<float>(t);
    // Footprint axes t|d|/f and t|d|^2/(f |dz|), |d|^2 ~ (1 + x^2)(1 + dz^2) split by row and
    // column.
    row_lod_[static_cast<size_t>(v)] = static_cast<float>(
        std::log2(t / fy) + 0.75 * std::log2(1.0 + dz * dz) - 0.5 * std::log2(dz));
  }
  col_dx_.resize(static_cast<size_t>(W));
  col_dy_.resize(static_cast<size_t>(W));
  col_top_.resize(static_cast<size_t>(W));
  col_bot_.resize(static_cast<size_t>(W));
  for (int u = 0; u < W; ++u)
    col_lod_[static_cast<size_t>(u)] =
        static_cast<float>(0.75 * std::log2(1.0 + view.xOf(u) * view.xOf(u)));
}

void ImageRenderer::drawWallColumn(const RenderFloor& floor, const LevelView& view, int u) {
  const double x = view.xOf(u);
  const double dxd = view.hf.x() - x * view.hl.x(), dyd = view.hf.y() - x * view.hl.y();
  const int id = nearest_[static_cast<size_t>(u)];
  const double cyl = view.cyl;
  int v_top = static_cast<int>(std::floor(cyl)) + 1, v_bot = v_top;  // wall rows [v_top, v_bot)
  if (id >= 0) {
    const Wall& w = floor.walls[static_cast<size_t>(id)];
    const double t = depth_[static_cast<size_t>(u)];
    const double fx = view.fx, fy = view.fy, above = view.above, below = view.below;
    const core::Vec3& c = view.c;
    v_top = std::clamp(static_cast<int>(std::ceil(cyl - fy * above / t)), 0, level_h_);
    v_bot = std::clamp(static_cast<int>(std::floor(cyl + fy * below / t)) + 1, v_top, level_h_);
    const double s =
        ((c.x() - w.p0x) * w.ex + (c.y() - w.p0y) * w.ey) + t * (w.ex * dxd + w.ey * dyd);
    const double nd = std::max(1e-6, -(w.nx * dxd + w.ny * dyd));
    const double dd = 1.0 + x * x;
    const float lod =
        static_cast<float>(std::log2(t * std::sqrt(dd) / fx) + 0.5 * std::log2(std::sqrt(dd) / nd));
    const Texture* tex = textures_.textures.data();
    int p_top = v_bot, p_bot = v_bot;  // poster rows [p_top, p_bot)
    const Poster& p = w.poster;
    float p_scale = 0.0f;
    if (p.texture >= 0 && s >= p.s0 && s <= p.s1) {
      const double height = floor.ceiling_z - floor.floor_z;
      p_top = std::clamp(static_cast<int>(std::ceil(cyl - fy * (above - (height - p.z1)) / t)),
                         v_top, v_bot);
      p_bot =
          std::clamp(static_cast<int>(std::floor(cyl + fy * (below - p.z0) / t)) + 1, p_top, v_bot);
      p_scale = static_cast<float>(tex[p.texture].size()) / (p.s1 - p.s0);
    }
    const Texture::Column column(tex[w.texture], static_cast<float>(s) * w.inv_texel + w.s_offset,
                                 mipLevel(lod + std::log2(w.inv_texel)));
    kernels::WallSpan span;
    span.column = &column;
    span.gain = w.gain_q8;
    span.v_top = v_top;
    // Texture row of image row v: (ceiling - z(v)) / texel, z(v) = c_z - t (v - cy) / fy.
    span.d_top = static_cast<float>(above - t * (cyl - v_top) / fy);  // metres below the ceiling
    span.step = static_cast<float>(t / fy);
    span.scale_z = w.inv_texel;
    span.offset_z = w.z_offset;
    const auto wall_span = avx2_ ? kernels::wallSpanAvx2 : kernels::wallSpan;
    uint16_t* out = level_.data() + u;
    wall_span(span, v_top, p_top, out, level_w_);
    if (p_top < p_bot) {
      const Texture::Column poster(tex[p.texture], (static_cast<float>(s) - p.s0) * p_scale,
                                   mipLevel(lod + std::log2(p_scale)));
      kernels::WallSpan on_poster = span;
      on_poster.column = &poster;
      on_poster.poster = true;
      on_poster.scale_z = p_scale;
      on_poster.offset_z = p.z1;
      on_poster.height = static_cast<float>(floor.ceiling_z - floor.floor_z);
      wall_span(on_poster, p_top, p_bot, out, level_w_);
    }
    wall_span(span, p_bot, v_bot, out, level_w_);
  }
  col_dx_[static_cast<size_t>(u)] = static_cast<float>(dxd);
  col_dy_[static_cast<size_t>(u)] = static_cast<float>(dyd);
  col_top_[static_cast<size_t>(u)] = v_top;
  col_bot_[static_cast<size_t>(u)] = v_bot;
}

void ImageRenderer::drawSurfaces(const RenderFloor& floor, const LevelView& view) {
  // Ceiling above the walls and floor below them, row by row (one depth per row).
  const Texture* tex = textures_.textures.data();
  const Texture& blank = tex[textures_.blank];
  const Texture* floor_of_cell[256];
  const Texture* ceiling_of_cell[256];
  int gain_of_cell[256];
  for (int cell = 0; cell < 256; ++cell) {
    const int label = cell & 0x7f;
    const Region& r = floor.regions[static_cast<size_t>(
        label > 0 && label <= static_cast<int>(floor.regions.size()) ? label - 1 : 0)];
    const bool featureless = (cell & 0x80) != 0;
    floor_of_cell[cell] = featureless ? &blank : &tex[r.floor_texture];
    ceiling_of_cell[cell] = featureless ? &blank : &tex[r.ceiling_texture];
    gain_of_cell[cell] = floor.floor_gain_q8[r.dark ? 1 : 0];
  }
  const float floor_log = std::log2(floor.floor_inv_texel),
              ceiling_log = std::log2(floor.ceiling_inv_texel);
  kernels::SurfaceRow row;
  row.cx = static_cast<float>(view.c.x());
  row.cy = static_cast<float>(view.c.y());
  row.col_dx = col_dx_.data();
  row.col_dy = col_dy_.data();
  row.col_lod = col_lod_.data();
  row.floor = &floor;
  row.gain_of_cell = gain_of_cell;
  const int W = level_w_;
  for (int v = 0; v < level_h_; ++v) {
    row.v = v;
    row.down = v > view.cyl;
    row.t = row_t_[static_cast<size_t>(v)];
    row.inv_texel = row.down ? floor.floor_inv_texel : floor.ceiling_inv_texel;
    row.lod_row = row_lod_[static_cast<size_t>(v)] + (row.down ? floor_log : ceiling_log);
    row.col_limit = row.down ? col_bot_.data() : col_top_.data();
    row.texture_of_cell = row.down ? floor_of_cell : ceiling_of_cell;
    (avx2_ ? kernels::surfaceRowAvx2 : kernels::surfaceRow)(
        row, W, level_.data() + static_cast<size_t>(v) * W);
  }
}

void ImageRenderer::fillLevelDepth() {
  // Wall rows at the column's depth, floor and ceiling rows at the row's.
  const int W = level_w_, H = level_h_;
  level_depth_.resize(static_cast<size_t>(W) * H);
  for (int v = 0; v < H; ++v) {
    float* d = level_depth_.data() + static_cast<size_t>(v) * W;
    const float row = row_t_[static_cast<size_t>(v)];
    for (int u = 0; u < W; ++u) {
      const bool wall =
          v >= col_top_[static_cast<size_t>(u)] && v < col_bot_[static_cast<size_t>(u)];
      d[u] = wall ? depth_[static_cast<size_t>(u)] : row;
    }
  }
}

void ImageRenderer::drawOccluders(const LevelView& view, std::span<const Occluder> occluders,
                                  bool with_depth) {
  // Passers-by in front of whatever is behind them.
  const int W = level_w_, H = level_h_;
  const double fx = view.fx, fy = view.fy, cyl = view.cyl, below = view.below;
  const core::Vec3& c = view.c;
  const Texture* tex = textures_.textures.data();
  for (int u = 0; u < W; ++u) {
    const double x = view.xOf(u);
    const double dxd = view.hf.x() - x * view.hl.x(), dyd = view.hf.y() - x * view.hl.y();
    const double t = depth_[static_cast<size_t>(u)];
    for (const Occluder& o : occluders) {
      const double den = o.normal.x() * dxd + o.normal.y() * dyd;
      if (den >= -1e-9) continue;
      const double to =
          ((o.centre.x() - c.x()) * o.normal.x() + (o.centre.y() - c.y()) * o.normal.y()) / den;
      if (!(to > 0.05) || !(to < t)) continue;
      const double ex = -o.normal.y(), ey = o.normal.x();
      const double so =
          (c.x() - o.centre.x()) * ex + (c.y() - o.centre.y()) * ey + to * (ex * dxd + ey * dyd);
      if (std::abs(so) > 0.5 * o.width_m) continue;
      const int o_top =
          std::clamp(static_cast<int>(std::ceil(cyl - fy * (o.height_m - below) / to)), 0, H);
      const int o_bot =
          std::clamp(static_cast<int>(std::floor(cyl + fy * below / to)) + 1, o_top, H);
      const float inv_texel = static_cast<float>(1.0 / o.texel_m);
      const float tu = static_cast<float>((so + 0.5 * o.width_m) * inv_texel);
      const float step = static_cast<float>(to / fy * inv_texel);
      const Texture& ot = tex[o.texture];
      const int level = mipLevel(static_cast<float>(std::log2(to / fx * inv_texel)));
      float tv = static_cast<float>((o.height_m - below + to * (o_top - cyl) / fy) * inv_texel);
      for (int v = o_top; v < o_bot; ++v, tv += step) {
        const int light = (ot.sample(tu, tv, level) * 200) >> 8;
        level_[static_cast<size_t>(v) * W + u] = static_cast<uint16_t>(light > 1023 ? 1023 : light);
      }
      if (with_depth) {
        for (int v = o_top; v < o_bot; ++v)
          level_depth_[static_cast<size_t>(v) * W + u] = static_cast<float>(to);
      }
    }
  }
}

void ImageRenderer::render(const RenderFloor& floor, double z_shift, const core::SE3d& world_T_cam,
                           std::span<const Occluder> occluders, cv::Mat* out, cv::Mat* depth) {
  const int W = camera_.width, H = camera_.height;
  out->create(H, W, CV_8UC1);
  const core::Mat3 R = world_T_cam.so3().matrix();
  const core::Vec3 c = world_T_cam.translation();
  core::Vec2 hf(R(0, 2), R(1, 2));
  if (hf.norm() < 1e-6) hf = core::Vec2(R(0, 1), R(1, 1));  // looking straight up or down
  hf.normalize();
  renderLevel(floor, z_shift, c, hf, occluders, depth != nullptr);

  // Real pixel -> level pixel: Kl * level_R_cam * K^-1 (the rotation about the common centre).
  core::Mat3 world_R_level;
  world_R_level.col(0) = core::Vec3(hf.y(), -hf.x(), 0.0);
  world_R_level.col(1) = core::Vec3(0.0, 0.0, -1.0);
  world_R_level.col(2) = core::Vec3(hf.x(), hf.y(), 0.0);
  core::Mat3 K, Kl;
  K << camera_.fx, 0, camera_.cx, 0, camera_.fy, camera_.cy, 0, 0, 1;
  Kl = K;
  Kl(0, 2) += kLevelMargin;
  Kl(1, 2) += kLevelMargin;
  const core::Mat3 M = Kl * world_R_level.transpose() * R * K.inverse();
  kernels::WarpRow warp;
  warp.level = level_.data();
  warp.level_w = level_w_;
  warp.max_u = static_cast<float>(level_w_ - 1) - 1e-3f;
  warp.max_v = static_cast<float>(level_h_ - 1) - 1e-3f;
  warp.response = response_.data();
  // The homography's denominator changes by ~1e-5 per pixel: exact every kBlock pixels,
  // linear in between (error far below 1e-3 pixel).
  constexpr int kBlock = 16;
  warp.block = kBlock;
  const int blocks = (W + kBlock - 1) / kBlock;
  thread_local std::vector<float> lu0, lv0, dlu, dlv;
  lu0.resize(static_cast<size_t>(blocks));
  lv0.resize(static_cast<size_t>(blocks));
  dlu.resize(static_cast<size_t>(blocks));
  dlv.resize(static_cast<size_t>(blocks));
  for (int v = 0; v < H; ++v) {
    const core::Vec3 h = M * core::Vec3(0.0, v, 1.0);
    core::Vec3 a = h;
    for (int b = 0; b < blocks; ++b) {
      const core::Vec3 next = h + (b + 1) * kBlock * M.col(0);
      lu0[static_cast<size_t>(b)] = static_cast<float>(a.x() / a.z());
      lv0[static_cast<size_t>(b)] = static_cast<float>(a.y() / a.z());
      dlu[static_cast<size_t>(b)] =
          static_cast<float>((next.x() / next.z() - a.x() / a.z()) / kBlock);
      dlv[static_cast<size_t>(b)] =
          static_cast<float>((next.y() / next.z() - a.y() / a.z()) / kBlock);
      a = next;
    }
    const int16_t* noise = noise_.data() + rng_.index(kNoiseTable);
    (avx2_ ? kernels::warpRowAvx2 : kernels::warpRow)(warp, lu0.data(), lv0.data(), dlu.data(),
                                                      dlv.data(), noise, W, out->ptr<uint8_t>(v));
  }
  if (depth) warpDepth(M, depth);
}

void ImageRenderer::warpDepth(const core::Mat3& M, cv::Mat* depth) const {
  const int W = camera_.width, H = camera_.height, LW = level_w_;
  depth->create(H, W, CV_32FC1);
  const double max_u = level_w_ - 1 - 1e-6, max_v = level_h_ - 1 - 1e-6;
  const core::Vec3 step = M.col(0);
  for (int v = 0; v < H; ++v) {
    float* out = depth->ptr<float>(v);
    const core::Vec3 h0 = M * core::Vec3(0.0, v, 1.0);
    for (int u = 0; u < W; ++u) {
      const double hx = h0.x() + u * step.x(), hy = h0.y() + u * step.y(),
                   hz = h0.z() + u * step.z();
      const double inv = 1.0 / hz;
      const double lu = std::clamp(hx * inv, 0.0, max_u), lv = std::clamp(hy * inv, 0.0, max_v);
      const int u0 = static_cast<int>(lu), v0 = static_cast<int>(lv);
      const double a = lu - u0, b = lv - v0;
      const float* p = level_depth_.data() + static_cast<size_t>(v0) * LW + u0;
      const float z00 = p[0], z01 = p[1], z10 = p[LW], z11 = p[LW + 1];
      const float lo = std::min({z00, z01, z10, z11}), hi = std::max({z00, z01, z10, z11});
      double z_level;
      if (hi <=
          lo *
              1.1f) {  // one surface (grazing floors change by up to ~5 % a pixel): bilinear in 1/z
        z_level = 1.0 / ((1 - b) * ((1 - a) / z00 + a / z01) + b * ((1 - a) / z10 + a / z11));
      } else {  // a depth edge: the nearest level pixel
        z_level = p[(b < 0.5 ? 0 : LW) + (a < 0.5 ? 0 : 1)];
      }
      out[u] = static_cast<float>(z_level * inv);
    }
  }
}

}  // namespace evermap::sim
