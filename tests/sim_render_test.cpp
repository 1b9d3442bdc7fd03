// The image-level simulator: geometry of the rendered stereo pairs, failure switches and the
// lighting of the sessions (the session, its sensors and its log: sim_image_session_test.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <opencv2/imgproc.hpp>

#include "tools/sim/image_session.h"
#include "tools/sim/render_world.h"
#include "tools/sim/stereo_renderer.h"

namespace evermap::sim {
namespace {

TextureLibrary testTextures() {
  Random rng(5);
  TextureOptions o;
  o.variants = 1;
  auto lib = makeTextureLibrary(o, {}, rng);
  EXPECT_TRUE(lib) << lib.error().message;
  return std::move(*lib);
}

// One square room of side 2 * half_m around the origin, floor at z = 0.
RenderFloor roomFloor(const TextureLibrary& lib, double half_m, bool dark, bool blank) {
  FloorSpec spec;
  Region r;
  r.boxes.push_back(Box{Vec2(-half_m, -half_m), Vec2(half_m, half_m)});
  r.dark = dark;
  spec.regions.push_back(r);
  if (blank) spec.blank_centres.push_back(Vec2::Zero());
  WorldOptions o;
  o.poster_probability = 0.0;
  o.blank_radius_m = 3.0 * half_m;
  // One texture per wall: the seams between wall pieces are point-sampled edges (aliased by
  // up to half a pixel), not what this geometry test is about.
  o.piece_min_m = o.piece_max_m = 4.0 * half_m;
  Random rng(11);
  auto floor = buildRenderFloor(spec, o, lib, rng);
  EXPECT_TRUE(floor) << floor.error().message;
  return std::move(*floor);
}

// A camera at (x, y, 1.2) with heading `yaw` (camera z along the heading, y down), the body
// rolled and pitched by (roll, pitch).
core::SE3d cameraAt(double x, double y, double yaw, double roll = 0.0, double pitch = 0.0) {
  const CameraOptions mount;  // x forward, y left, z up -> camera axes
  core::SE3d body(core::SO3d::exp(Vec3(0, 0, yaw)) * core::SO3d::exp(Vec3(roll, pitch, 0)),
                  Vec3(x, y, 0.0));
  core::SE3d body_T_cam = mount.bodyTCam();
  body_T_cam = core::SE3d(body_T_cam.so3(), Vec3(0, 0, 1.2));
  return body * body_T_cam;
}

// The camera of the room tests: 320 x 240, 90° wide (what vo-proc sees of a room).
constexpr PinholeCamera kRoomCamera{320, 240, 225.0, 225.0, 160.0, 120.0};

// A passer-by `width_m` wide standing at `centre`, facing -x (towards a camera at the middle).
Occluder passerBy(const TextureLibrary& lib, const Vec2& centre, double width_m) {
  Occluder person;
  person.centre = centre;
  person.normal = Vec2(-1, 0);
  person.width_m = width_m;
  person.texture = lib.people.front();
  return person;
}

// The 4 m room seen from its middle, 0.3 rad to the left, with pixel noise `noise`.
cv::Mat renderRoom(const TextureLibrary& lib, double noise, bool dark, bool blank) {
  ImageRenderer renderer(lib, kRoomCamera, noise, 3);
  cv::Mat image;
  renderer.render(roomFloor(lib, 4.0, dark, blank), 0.0, cameraAt(0, 0, 0.3), {}, &image);
  return image;
}

// Bilinear sample of a gray image.
double at(const cv::Mat& im, double x, int y) {
  const int x0 = static_cast<int>(std::floor(x));
  const double a = x - x0;
  return (1 - a) * im.at<uint8_t>(y, x0) + a * im.at<uint8_t>(y, x0 + 1);
}

constexpr int kPatch = 8;  // half size of the matched patch

// Disparity at left pixel (u, v): the best integer shift by SSD along the row, refined by
// Gauss-Newton on the bilinear right image (Lucas-Kanade in one dimension). NaN when it does
// not converge.
double matchDisparity(const cv::Mat& left, const cv::Mat& right, int u, int v, int max_d,
                      double slope) {
  auto cost = [&](double d) {
    double s = 0.0;
    for (int dy = -kPatch; dy <= kPatch; ++dy) {
      for (int dx = -kPatch; dx <= kPatch; ++dx) {
        const double e =
            left.at<uint8_t>(v + dy, u + dx) - at(right, u + dx - d - slope * dx, v + dy);
        s += e * e;
      }
    }
    return s;
  };
  int best = 1;
  for (int d = 1; d <= max_d && u - d - kPatch - 1 >= 0; ++d) {
    if (cost(d) < cost(best)) best = d;
  }
  // On a slanted wall the disparity changes across the patch by `slope` per pixel (from the
  // plane, the stereo model's prediction of the patch's shape); d at the centre is measured:
  // right pixel x = u + dx - (d + slope dx).
  double d = best;
  for (int it = 0; it < 50; ++it) {
    double num = 0.0, den = 0.0;
    for (int dy = -kPatch; dy <= kPatch; ++dy) {
      for (int dx = -kPatch; dx <= kPatch; ++dx) {
        const double x = u + dx - d - slope * dx;
        const double g = 0.5 * (at(right, x + 1, v + dy) - at(right, x - 1, v + dy));
        num += g * (left.at<uint8_t>(v + dy, u + dx) - at(right, x, v + dy));
        den += g * g;
      }
    }
    if (!(den > 0)) return std::nan("");
    const double step = -num / den;
    d += std::clamp(step, -0.5, 0.5);
    if (std::abs(step) < 1e-3) return d;
  }
  return std::nan("");
}

// Mean absolute horizontal gradient over the patch: texture that fixes the disparity.
double horizontalTexture(const cv::Mat& im, int u, int v) {
  double s = 0.0;
  for (int dy = -kPatch; dy <= kPatch; ++dy) {
    for (int dx = -kPatch; dx <= kPatch; ++dx)
      s += std::abs(im.at<uint8_t>(v + dy, u + dx + 1) - im.at<uint8_t>(v + dy, u + dx - 1));
  }
  return s / ((2 * kPatch + 1) * (2 * kPatch + 1));
}

TEST(SimRender, RenderedPointAppearsWhereTheStereoModelSays) {
  const TextureLibrary lib = testTextures();
  const RenderFloor floor = roomFloor(lib, 10.0, false, false);
  const PinholeCamera cam{640, 480, 450.0, 450.0, 320.0, 240.0};
  const double baseline = 0.12;
  auto stereo =
      core::StereoCamera::create(cam.fx, cam.fy, cam.cx, cam.cy, baseline, cam.width, cam.height);
  ASSERT_TRUE(stereo);
  ImageRenderer renderer(lib, cam, 0.0, 1);
  // Facing the wall x = 10 square on (depth 2.5 m), turned by 20 degrees (a slanted wall), and
  // rolled and pitched as on a rough floor (the image is then resampled from a level view).
  for (const auto& [yaw, tilt] :
       {std::pair{0.0, 0.0}, std::pair{20.0 * std::numbers::pi / 180.0, 0.0},
        std::pair{0.2, 0.006}}) {
    const core::SE3d world_T_left = cameraAt(7.5, 0.5, yaw, tilt, -0.7 * tilt);
    const core::SE3d world_T_right = world_T_left * core::SE3d(core::SO3d(), Vec3(baseline, 0, 0));
    cv::Mat left, right;
    renderer.render(floor, 0.0, world_T_left, {}, &left);
    renderer.render(floor, 0.0, world_T_right, {}, &right);
    int checked = 0, unmatched = 0;
    std::vector<double> ratios;
    for (int v = 100; v <= 380; v += 20) {
      for (int u = 100; u <= 540; u += 20) {
        // The 3-D point seen at (u, v): the ray through the pixel meets the wall x = 10.
        const Vec3 ray_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
        const Vec3 ray_world = world_T_left.so3() * ray_cam;
        const Vec3 c = world_T_left.translation();
        const double t = (10.0 - c.x()) / ray_world.x();
        const Vec3 p_world = c + t * ray_world;
        if (std::abs(p_world.y()) > 9.5 || p_world.z() < 0.2 || p_world.z() > 2.6) continue;
        if (horizontalTexture(left, u, v) < 6.0) continue;  // too little texture to match
        const auto uvd = stereo->project(world_T_left.inverse() * p_world);
        ASSERT_TRUE(uvd);
        EXPECT_NEAR((*uvd)[0], u, 1e-6);
        // The disparity one pixel to each side, for the slope across the patch.
        auto disparityAt = [&](double uu) {
          const Vec3 r =
              world_T_left.so3() * Vec3((uu - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
          return (*stereo->project(world_T_left.inverse() * (c + (10.0 - c.x()) / r.x() * r)))[2];
        };
        const double slope = 0.5 * (disparityAt(u + 1) - disparityAt(u - 1));
        const double d = matchDisparity(left, right, u, v, 40, slope);
        if (!std::isfinite(d)) {
          ++unmatched;
          continue;
        }
        const double depth = stereo->depthFromDisparity(d);
        const double truth = (world_T_left.inverse() * p_world).z();
        ratios.push_back(depth / truth);
        // A level camera renders each pixel exactly; a tilted one is resampled from a level
        // view (bilinear), which moves single patches by up to ~0.3 px.
        EXPECT_NEAR(depth / truth, 1.0, tilt == 0.0 ? 0.01 : 0.025)
            << "pixel " << u << "," << v << " yaw " << yaw << ": disparity " << d << " vs "
            << (*uvd)[2];
        ++checked;
      }
    }
    EXPECT_GE(checked, 40) << "yaw " << yaw;
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    EXPECT_NEAR(ratios[ratios.size() / 2], 1.0, 0.005) << "median, yaw " << yaw;
    EXPECT_LE(unmatched, checked / 10) << "yaw " << yaw;
  }
}

TEST(SimRender, LightsOffGiveADarkImage) {
  const TextureLibrary lib = testTextures();
  const cv::Mat lit = renderRoom(lib, 2.0, false, false);
  const cv::Mat dark = renderRoom(lib, 2.0, true, false);
  EXPECT_GT(cv::mean(lit)[0], 60.0);
  EXPECT_LT(cv::mean(dark)[0], 15.0);
}

TEST(SimRender, FeaturelessZoneGivesAFlatImage) {
  const TextureLibrary lib = testTextures();
  const cv::Mat textured = renderRoom(lib, 0.0, false, false);
  const cv::Mat blank = renderRoom(lib, 0.0, false, true);
  cv::Mat gx_t, gx_b;
  cv::Scalar m, sd_t, sd_b;
  cv::Laplacian(textured, gx_t, CV_32F);
  cv::Laplacian(blank, gx_b, CV_32F);
  cv::meanStdDev(gx_t, m, sd_t);
  cv::meanStdDev(gx_b, m, sd_b);
  EXPECT_GT(sd_t[0], 10.0);
  EXPECT_LT(sd_b[0], 2.0);  // only the texture's gentle shading and the room's corners
}

TEST(SimRender, PasserByCoversMostOfTheView) {
  const TextureLibrary lib = testTextures();
  ImageRenderer renderer(lib, kRoomCamera, 0.0, 3);
  const RenderFloor floor = roomFloor(lib, 6.0, false, false);
  cv::Mat free, blocked;
  renderer.render(floor, 0.0, cameraAt(0, 0, 0), {}, &free);
  const Occluder person = passerBy(lib, Vec2(0.8, 0.0), 1.0);
  renderer.render(floor, 0.0, cameraAt(0, 0, 0), std::vector<Occluder>{person}, &blocked);
  const double changed = cv::countNonZero(free != blocked) / static_cast<double>(free.total());
  EXPECT_GT(changed, 0.6);
}

// The surface seen through pixel (u, v), by casting its ray against the square room of
// roomFloor (walls at ±half_m, floor at floor_z, ceiling at ceiling_z) and an optional
// passer-by: its depth along the camera's z axis and which surface it is (0-5 the room's
// planes, 6 the passer-by).
struct Hit {
  double depth = std::numeric_limits<double>::infinity();
  int surface = -1;
};
Hit rayCast(const PinholeCamera& cam, const core::SE3d& world_T_cam, double half_m, double floor_z,
            double ceiling_z, const Occluder* person, double u, double v) {
  const Vec3 d =
      world_T_cam.so3() * Vec3((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);  // z_cam = 1
  const Vec3 c = world_T_cam.translation();
  Hit best;
  int id = 0;
  for (const auto& [axis, value] :
       {std::pair{0, half_m}, std::pair{0, -half_m}, std::pair{1, half_m}, std::pair{1, -half_m},
        std::pair{2, floor_z}, std::pair{2, ceiling_z}}) {
    const double t = std::abs(d[axis]) < 1e-12 ? -1.0 : (value - c[axis]) / d[axis];
    if (t > 0.0 && t < best.depth) best = Hit{t, id};
    ++id;
  }
  if (person) {
    const Vec2 n = person->normal;
    const double den = n.x() * d.x() + n.y() * d.y();
    const double t =
        ((person->centre.x() - c.x()) * n.x() + (person->centre.y() - c.y()) * n.y()) / den;
    const Vec3 p = c + t * d;
    const double side =
        (p.x() - person->centre.x()) * -n.y() + (p.y() - person->centre.y()) * n.x();
    if (t > 0.0 && t < best.depth && std::abs(side) <= 0.5 * person->width_m && p.z() >= floor_z &&
        p.z() <= floor_z + person->height_m) {
      best = Hit{t, 6};
    }
  }
  return best;
}

TEST(SimRender, RenderedDepthIsTheRayCastDepth) {
  const TextureLibrary lib = testTextures();
  const PinholeCamera& cam = kRoomCamera;
  ImageRenderer renderer(lib, cam, 0.0, 3);
  const double half = 3.0;
  const RenderFloor floor = roomFloor(lib, half, false, false);
  const Occluder person = passerBy(lib, Vec2(0.2, 0.3), 0.8);
  // Level and square-on, then turned, rolled and pitched as the robot on a rough floor.
  for (const auto& [world_T_cam, with_person] :
       {std::pair{cameraAt(-1.0, 0.0, 0.0), true},
        std::pair{cameraAt(-1.0, 0.5, 0.6, 0.01, -0.015), false},
        std::pair{cameraAt(0.5, -1.0, 2.2, -0.012, 0.008), false}}) {
    cv::Mat gray, depth;
    const std::vector<Occluder> occluders =
        with_person ? std::vector<Occluder>{person} : std::vector<Occluder>{};
    renderer.render(floor, 0.0, world_T_cam, occluders, &gray, &depth);
    ASSERT_EQ(depth.type(), CV_32FC1);
    ASSERT_EQ(depth.size(), gray.size());
    std::vector<double> errors;
    int seams = 0, seams_off = 0, jumps = 0;
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const Occluder* p = with_person ? &person : nullptr;
        const Hit truth = rayCast(cam, world_T_cam, half, floor.floor_z, floor.ceiling_z, p, u, v);
        // Where two surfaces meet within a pixel (corners of the room, the passer-by's
        // outline), the rendered depth is either side's or between them.
        bool seam = false, jump = false;
        for (const auto& [du, dv] :
             {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
          const Hit n =
              rayCast(cam, world_T_cam, half, floor.floor_z, floor.ceiling_z, p, u + du, v + dv);
          seam = seam || n.surface != truth.surface;
          jump = jump || std::abs(n.depth - truth.depth) > 0.1 * truth.depth;
        }
        const double rel = std::abs(depth.at<float>(v, u) - truth.depth) / truth.depth;
        if (jump) {
          ++jumps;
        } else if (seam) {
          ++seams;
          seams_off += rel > 0.03;
        } else {
          errors.push_back(rel);
        }
      }
    }
    std::sort(errors.begin(), errors.end());
    EXPECT_EQ(jumps > 0, with_person);
    EXPECT_GT(seams, 100);
    EXPECT_EQ(seams_off, 0) << "corner pixels more than 3 % off the ray cast";
    EXPECT_LT(errors[errors.size() / 2], 1e-4);  // median: float precision
    EXPECT_LT(errors.back(), 1e-3) << "inside a surface: bilinear in inverse depth is exact";
  }
}

TEST(ImageSession, LightingChangesBetweenSessions) {
  LightingOptions o;
  o.gain_jitter = 0.3;
  o.offset_jitter_gray = 10.0;
  o.gamma_jitter = 0.2;
  const Lighting s0 = o.forSession(0, 7), s1 = o.forSession(1, 7), s2 = o.forSession(2, 7);
  EXPECT_EQ(s0.gain, 1.0);
  EXPECT_EQ(s0.gamma, 1.0);
  EXPECT_NE(s1.gain, s2.gain);
  for (const Lighting& l : {s1, s2}) {
    EXPECT_NEAR(l.gain, 1.0, 0.3);
    EXPECT_NEAR(l.offset_gray, 0.0, 10.0);
    EXPECT_NEAR(l.gamma, 1.0, 0.2);
  }
  // The same view, brighter or darker by the session's response.
  const TextureLibrary lib = testTextures();
  const PinholeCamera cam{160, 120, 110.0, 110.0, 80.0, 60.0};
  ImageRenderer renderer(lib, cam, 0.0, 3);
  const RenderFloor floor = roomFloor(lib, 4.0, false, false);
  cv::Mat base, dim;
  renderer.render(floor, 0.0, cameraAt(0, 0, 0.3), {}, &base);
  renderer.setLighting(Lighting{0.5, 0.0, 1.0});
  renderer.render(floor, 0.0, cameraAt(0, 0, 0.3), {}, &dim);
  EXPECT_NEAR(cv::mean(dim)[0], 0.5 * cv::mean(base)[0], 1.0);
}

}  // namespace
}  // namespace evermap::sim
