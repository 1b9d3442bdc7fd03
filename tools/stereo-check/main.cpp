// evermap-stereo-check: is a rectified KITTI-layout stereo sequence consistent with its
// calibration and its ground truth? Metric checks that do not go through visual odometry:
//
//  1. calibration: calib.txt against KITTI's published odometry calibrations;
//  2. rectification: row offset (right - left) of corners matched in 2-D between the images,
//     and how low the disparities go when negative ones are allowed (a point at infinity has
//     d = 0; d < 0 means the images' principal points do not match the calibration's);
//  3. road plane: disparities of a grid of road pixels (core StereoDepth, the pipeline's),
//     robustly fitted by d = a (u - cx) + b (v - cy) + c, the exact image of a 3-D plane. The
//     camera height is h = B / |(a, b, c / f)|: it depends on the baseline, not on f, and (c
//     being a few pixels against f) hardly on a disparity offset. KITTI: 1.65 m (Geiger et
//     al., IJRR 2013, fig. 3).
//  4. with ground truth: the disparity offset that puts the camera's own future positions
//     (ground truth, their direction only) on the road plane it saw; a disparity offset moves
//     the plane's horizon (c), a baseline error does not.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/common/percentile.h"
#include "core/features/image_pyramid.h"
#include "core/features/orb_descriptor.h"
#include "core/features/patch_alignment.h"
#include "core/features/stereo_depth.h"
#include "core/features/stereo_features.h"
#include "core/registration/frame_registration.h"
#include "core/registration/keyframe_features.h"
#include "tools/datasets/kitti.h"
#include "core/registration/disparity_offset.h"

namespace {

using evermap::datasets::KittiProjections;

struct Published {
  const char* sequences;
  double fx, cx, cy, p1_03;  // P0 = P1 = K; P1(0,3) = -fx b
};
// KITTI odometry devkit calib.txt (data_odometry_calib.zip), P0 and P1 of the gray cameras.
constexpr Published kPublished[] = {
    {"00-02, 13-21", 718.856, 607.1928, 185.2157, -386.1448},
    {"03", 721.5377, 609.5593, 172.854, -387.5744},
    {"04-12", 707.0912, 601.8873, 183.1104, -379.8145},
};

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
double quantile(std::vector<double> v, double q) {
  return v.empty() ? std::nan("") : evermap::percentile(std::move(v), q);
}
double mad(const std::vector<double>& v) {
  const double m = median(v);
  std::vector<double> a;
  for (double x : v) a.push_back(std::abs(x - m));
  return 1.4826 * median(a);
}

// SAD (7x7) disparity search over [dmin, dmax] (dmin may be negative) at level 0, integer.
bool sadSearch(const cv::Mat& L, const cv::Mat& R, int u, int v, int dmin, int dmax, int* best) {
  const int r = 3;
  if (v - r - 1 < 0 || v + r + 1 >= L.rows || u - r - 1 < 0 || u + r + 1 >= L.cols) return false;
  int best_cost = 1 << 30, second = 1 << 30, best_d = 0;
  std::vector<int> cost;
  for (int d = dmin; d <= dmax; ++d) {
    const int x = u - d;
    if (x - r - 1 < 0 || x + r + 1 >= R.cols) {
      cost.push_back(1 << 30);
      continue;
    }
    int c = 0;
    for (int dy = -r; dy <= r; ++dy) {
      const uint8_t* l = L.ptr<uint8_t>(v + dy);
      const uint8_t* rr = R.ptr<uint8_t>(v + dy);
      for (int dx = -r; dx <= r; ++dx) c += std::abs(int(l[u + dx]) - int(rr[x + dx]));
    }
    cost.push_back(c);
    if (c < best_cost) {
      best_cost = c;
      best_d = d;
    }
  }
  for (int d = dmin; d <= dmax; ++d) {
    if (std::abs(d - best_d) > 1) second = std::min(second, cost[d - dmin]);
  }
  if (best_cost > 12 * 49 || best_cost >= 0.8 * second) return false;
  *best = best_d;
  return true;
}

struct PlaneFit {
  double a = 0, b = 0, c = 0;  // d = a (u - cx) + b (v - cy) + c
  int inliers = 0;
  double rms_px = 0;
};

// RANSAC (three points) then least squares on the points within `tol_px`.
PlaneFit fitDisparityPlane(const std::vector<cv::Point3d>& uvd, double tol_px, uint32_t seed) {
  PlaneFit best;
  if (uvd.size() < 20) return best;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, uvd.size() - 1);
  auto solve = [](const std::vector<const cv::Point3d*>& pts, PlaneFit* f) {
    cv::Mat A(static_cast<int>(pts.size()), 3, CV_64F), y(static_cast<int>(pts.size()), 1, CV_64F);
    for (size_t i = 0; i < pts.size(); ++i) {
      A.at<double>(int(i), 0) = pts[i]->x;
      A.at<double>(int(i), 1) = pts[i]->y;
      A.at<double>(int(i), 2) = 1.0;
      y.at<double>(int(i), 0) = pts[i]->z;
    }
    cv::Mat x;
    if (!cv::solve(A, y, x, cv::DECOMP_SVD)) return false;
    f->a = x.at<double>(0);
    f->b = x.at<double>(1);
    f->c = x.at<double>(2);
    return true;
  };
  int best_count = -1;
  PlaneFit cand;
  for (int it = 0; it < 300; ++it) {
    std::vector<const cv::Point3d*> s = {&uvd[pick(rng)], &uvd[pick(rng)], &uvd[pick(rng)]};
    if (!solve(s, &cand)) continue;
    int count = 0;
    for (const auto& p : uvd)
      count += std::abs(cand.a * p.x + cand.b * p.y + cand.c - p.z) < tol_px;
    if (count > best_count) {
      best_count = count;
      best.a = cand.a;
      best.b = cand.b;
      best.c = cand.c;
    }
  }
  for (int refine = 0; refine < 3; ++refine) {
    std::vector<const cv::Point3d*> in;
    for (const auto& p : uvd) {
      if (std::abs(best.a * p.x + best.b * p.y + best.c - p.z) < tol_px) in.push_back(&p);
    }
    if (in.size() < 10 || !solve(in, &best)) break;
    best.inliers = static_cast<int>(in.size());
    double ss = 0;
    for (const auto* p : in) ss += std::pow(best.a * p->x + best.b * p->y + best.c - p->z, 2);
    best.rms_px = std::sqrt(ss / in.size());
  }
  return best;
}

// The checks' settings (--help lists them, --print-config prints them).
struct CheckOptions {
  int step = 5;
  double height_m = 1.65, offset_px = 0.0, road_margin_px = 30.0, road_half_width = 0.25;
  double ahead_min_m = 6.0, ahead_max_m = 20.0;
  bool self_offset = false;

  void declareOptions(evermap::OptionList& o) {
    o.add("step", &step, "", "every N-th frame").min(1);
    o.add("camera_height_m", &height_m, "m", "the rig's known height above the road (KITTI 1.65)")
        .positive();
    o.add("disparity_offset_px", &offset_px, "px",
          "hypothesis: true disparity = measured + this (the plane fit and height under it)")
        .in(-20, 20);
    o.add("road_margin_px", &road_margin_px, "px", "road pixels start this far below cy").min(0);
    o.add("road_half_width", &road_half_width, "",
          "road pixels within this fraction of the width around cx")
        .positive()
        .max(0.5);
    o.add("ahead_min_m", &ahead_min_m, "m", "ground-truth positions used from this far ahead")
        .min(0);
    o.add("ahead_max_m", &ahead_max_m, "m", "... up to this far").positive();
    o.add("self_offset", &self_offset,
          "estimate the disparity offset from consecutive frames alone (registration, no ground "
          "truth; slower)");
  }
};

// The command line: the sequence and its folders beside the settings.
struct CheckArgs {
  std::string sequence, left, right, poses;
  CheckOptions options;
};

// The command line into `a`: -1 to run, else main's exit status.
int parseCommandLine(int argc, char** argv, CheckArgs* a) {
  std::vector<std::string> positional;
  evermap::CommandLine cli(
      "evermap-stereo-check",
      "Checks a rectified KITTI-layout stereo sequence against its calibration and ground truth "
      "without odometry: published calibration, row offsets, road-plane camera height, disparity "
      "offset.");
  cli.positional(&positional, "SEQUENCE",
                 "folder with image_0/image_1 (or image_l/image_r), calib.txt, optional poses.txt");
  cli.value("--left", &a->left, "DIR", "left image folder (relative to SEQUENCE)");
  cli.value("--right", &a->right, "DIR", "right image folder");
  cli.value("--poses", &a->poses, "FILE", "ground truth (default SEQUENCE/poses.txt when present)");
  cli.options(&a->options);
  cli.alias("--step", "step", "N");
  cli.alias("--camera-height", "camera_height_m", "M");
  cli.alias("--disparity-offset", "disparity_offset_px", "PX");
  cli.alias("--road-margin", "road_margin_px", "PX");
  cli.alias("--road-half-width", "road_half_width", "FRACTION");
  cli.alias("--ahead-min", "ahead_min_m", "M");
  cli.alias("--ahead-max", "ahead_max_m", "M");
  cli.alias("--self-offset", "self_offset", "");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (positional.size() != 1) {
    std::fprintf(stderr, "evermap-stereo-check: expected SEQUENCE (--help)\n");
    return 2;
  }
  a->sequence = positional[0];
  return -1;
}

// The calibration's intrinsics and baseline, from the projection matrices.
struct Rig {
  double f = 0, fy = 0, cx = 0, cy = 0, B = 0;
};

Rig printCalibration(const evermap::datasets::KittiSequence& seq) {
  const KittiProjections& P = seq.projections;
  Rig rig{P.P0(0, 0), P.P0(1, 1), P.P0(0, 2), P.P0(1, 2), -P.P1(0, 3) / P.P1(0, 0)};
  std::printf("calibration  %s: fx %.4f fy %.4f cx %.4f cy %.4f, right cx %.4f, baseline %.5f m\n",
              seq.calib_file.c_str(), rig.f, rig.fy, rig.cx, rig.cy, P.P1(0, 2), rig.B);
  for (const auto& p : kPublished) {
    const bool same = std::abs(p.fx - rig.f) < 1e-3 && std::abs(p.cx - rig.cx) < 1e-3 &&
                      std::abs(p.cy - rig.cy) < 1e-3 && std::abs(p.p1_03 - P.P1(0, 3)) < 1e-3 &&
                      std::abs(P.P1(0, 2) - rig.cx) < 1e-3;
    std::printf("  KITTI odometry %-13s fx %.4f cx %.4f cy %.4f b %.5f m: %s\n", p.sequences, p.fx,
                p.cx, p.cy, -p.p1_03 / p.fx, same ? "identical" : "differs");
  }
  return rig;
}

// What the per-frame checks gather over the sequence.
struct Tallies {
  std::vector<double> dy_all, dy_left, dy_mid, dy_right, dy_top, dy_bottom, d_all;
  std::vector<double> heights, offsets;
  int frames_used = 0;
};

// 2. Rectification: corners, integer disparity (negative allowed), then 2-D alignment.
std::vector<double> rowOffsets(const cv::Mat& L, const cv::Mat& R, double cy, Tallies* t) {
  std::vector<cv::KeyPoint> corners;
  cv::FAST(L, corners, 25, true);
  std::vector<double> dy_frame;
  evermap::core::PatchAlignmentOptions align2d;
  align2d.radius_px = 4;
  align2d.max_shift_px = 2.0;
  for (size_t i = 0; i < corners.size(); i += std::max<size_t>(1, corners.size() / 1500)) {
    const int u = static_cast<int>(corners[i].pt.x), v = static_cast<int>(corners[i].pt.y);
    int d = 0;
    if (!sadSearch(L, R, u, v, -16, 160, &d)) continue;
    const auto x =
        evermap::core::alignPatch(L, u, v, R, Eigen::Vector2f(float(u - d), float(v)), align2d);
    if (!x) continue;
    const double dy = x->y() - v;
    const double disp = u - x->x();
    dy_frame.push_back(dy);
    t->dy_all.push_back(dy);
    t->d_all.push_back(disp);
    (u < L.cols / 3 ? t->dy_left : u < 2 * L.cols / 3 ? t->dy_mid : t->dy_right).push_back(dy);
    (v < cy ? t->dy_top : t->dy_bottom).push_back(dy);
  }
  return dy_frame;
}

// 3. Road plane from the pipeline's stereo depth on a grid below the horizon: disparities as
// measured (calib.txt's camera, offset 0), the hypothesis added here.
std::vector<cv::Point3d> roadDisparities(const evermap::core::StereoDepth& depth,
                                         const evermap::core::StereoCamera& measuring,
                                         const evermap::core::ImagePyramid& pl,
                                         const evermap::core::ImagePyramid& pr, const Rig& rig,
                                         const cv::Size& size, const CheckOptions& o) {
  std::vector<cv::Point3d> uvd;
  for (int v = static_cast<int>(rig.cy + o.road_margin_px); v < size.height - 8; v += 4) {
    for (int u = static_cast<int>(rig.cx - o.road_half_width * size.width);
         u <= rig.cx + o.road_half_width * size.width; u += 6) {
      evermap::core::Keypoint kp;
      kp.u = static_cast<float>(u);
      kp.v = static_cast<float>(v);
      const float d = depth.disparity(measuring, pl, pr, kp);
      if (std::isfinite(d)) uvd.emplace_back(u - rig.cx, v - rig.cy, d + o.offset_px);
    }
  }
  return uvd;
}

// 4. The camera's positions ahead (ground truth, in this camera's frame) lie on the road plane:
// a x + b y + (c + delta) z / f = 0 for each, solved for delta (direction only).
double groundTruthOffset(const evermap::datasets::KittiSequence& seq, size_t frame,
                         const PlaneFit& fit, const Rig& rig, const CheckOptions& o) {
  std::vector<double> ds;
  const auto& w_T_k = seq.poses[frame];
  for (size_t m = frame + 1; m < seq.poses.size(); ++m) {
    const Eigen::Vector3d p = (w_T_k.inverse() * seq.poses[m]).translation();
    if (p.z() < o.ahead_min_m || p.z() > o.ahead_max_m) continue;
    ds.push_back(-rig.f * (fit.a * p.x() + fit.b * p.y() * (rig.f / rig.fy)) / p.z() - fit.c);
  }
  return ds.empty() ? std::nan("") : median(ds);
}

// Checks 2-4 on one frame, its row printed; 1 on an unreadable frame.
int checkFrame(const evermap::datasets::KittiSequence& seq, size_t frame, const Rig& rig,
               const evermap::core::StereoDepth& depth, const CheckOptions& o, Tallies* t) {
  const cv::Mat L = cv::imread(seq.leftImage(frame).string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat R = cv::imread(seq.rightImage(frame).string(), cv::IMREAD_GRAYSCALE);
  if (L.empty() || R.empty() || L.size() != R.size()) {
    std::fprintf(stderr, "evermap-stereo-check: frame %zu: unreadable or mismatched images\n",
                 frame);
    return 1;
  }
  ++t->frames_used;
  evermap::core::ImagePyramid pl, pr;
  if (!pl.build(L, 1) || !pr.build(R, 1)) return 1;
  const std::vector<double> dy_frame = rowOffsets(L, R, rig.cy, t);
  const auto measuring =
      evermap::core::StereoCamera::create(rig.f, rig.fy, rig.cx, rig.cy, rig.B, L.cols, L.rows);
  if (!measuring) {
    std::fprintf(stderr, "evermap-stereo-check: %s\n", measuring.error().message.c_str());
    return 1;
  }
  const std::vector<cv::Point3d> uvd = roadDisparities(depth, *measuring, pl, pr, rig, L.size(), o);
  const PlaneFit fit = fitDisparityPlane(uvd, 0.5, 7u + static_cast<uint32_t>(frame));
  const double f = rig.f, fy = rig.fy;
  const double h = rig.B / std::sqrt(fit.a * fit.a + fit.b * fit.b * (f / fy) * (f / fy) +
                                     (fit.c / f) * (fit.c / f));
  if (fit.inliers >= 50) t->heights.push_back(h);
  double delta = std::nan("");
  if (!seq.poses.empty() && fit.inliers >= 50) {
    delta = groundTruthOffset(seq, frame, fit, rig, o);
    if (std::isfinite(delta)) t->offsets.push_back(delta);
  }
  std::printf("%6zu %8.3f %8.5f %8.5f %7.2f %6d %8.3f %8.3f %9.2f\n", frame, median(dy_frame),
              fit.a, fit.b, fit.c, fit.inliers, fit.rms_px, h, delta);
  return 0;
}

void printRectification(const Tallies& t) {
  std::printf(
      "\nrectification: %zu corners in %d frames, row offset right - left: median %.3f px, robust "
      "sigma %.3f px\n",
      t.dy_all.size(), t.frames_used, median(t.dy_all), mad(t.dy_all));
  std::printf("  by column third: %.3f / %.3f / %.3f px; above / below cy: %.3f / %.3f px\n",
              median(t.dy_left), median(t.dy_mid), median(t.dy_right), median(t.dy_top),
              median(t.dy_bottom));
  const auto& d_all = t.d_all;
  std::printf(
      "disparities (negative allowed): p0.5 %.2f px, p1 %.2f px, p5 %.2f px, %.2f %% below -0.5 "
      "px\n",
      quantile(d_all, 0.005), quantile(d_all, 0.01), quantile(d_all, 0.05),
      100.0 * std::count_if(d_all.begin(), d_all.end(), [](double d) { return d < -0.5; }) /
          std::max<size_t>(1, d_all.size()));
  std::printf("  lowest disparities (0.25 px bins from -2 px):");
  int bins[16] = {0};
  for (double d : d_all) {
    const int b = static_cast<int>(std::floor((d + 2.0) / 0.25));
    if (b >= 0 && b < 16) ++bins[b];
  }
  for (int b = 0; b < 16; ++b) std::printf(" %d", bins[b]);
  std::printf("\n");
}

void printRoadPlane(const Tallies& t, const Rig& rig, double height_m) {
  const auto& heights = t.heights;
  std::printf(
      "road plane: camera height median %.3f m (p10 %.3f, p90 %.3f; %zu frames) against %.3f m: "
      "ratio %.4f\n",
      median(heights), quantile(heights, 0.1), quantile(heights, 0.9), heights.size(), height_m,
      median(heights) / height_m);
  std::printf("  baseline that gives %.3f m: %.4f m (calib.txt %.4f m)\n", height_m,
              rig.B * height_m / median(heights), rig.B);
}

// Consecutive frames registered (ORB, registerFrames), their matches with the hypothesis added.
int registeredPairs(const evermap::datasets::KittiSequence& seq, const Rig& rig, double offset_px,
                    evermap::Expected<evermap::core::StereoCamera>* camera,
                    std::vector<evermap::core::StereoMatchPair>* pairs) {
  evermap::core::StereoFeatureExtractor::Options fo;
  auto extractor = evermap::core::StereoFeatureExtractor::create(fo);
  evermap::core::OrbExtractor orb{evermap::core::OrbExtractor::Options{}};
  evermap::core::KeyframeFeatures previous;
  for (size_t k = 0; k < seq.frames.size(); ++k) {
    const size_t frame = seq.frames[k];
    const cv::Mat L = cv::imread(seq.leftImage(frame).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat R = cv::imread(seq.rightImage(frame).string(), cv::IMREAD_GRAYSCALE);
    if (k == 0) {
      *camera =
          evermap::core::StereoCamera::create(rig.f, rig.fy, rig.cx, rig.cy, rig.B, L.cols, L.rows);
    }
    if (!*camera || !extractor) return 1;
    evermap::core::FeatureFrame ff;
    if (!extractor->extract(**camera, static_cast<int64_t>(k), L, R, &ff)) return 1;
    evermap::core::KeyframeFeatures kf = evermap::core::makeKeyframeFeatures(ff, orb);
    if (k > 0) {
      const auto s = evermap::core::registerFrames(**camera, previous, **camera, kf,
                                                   evermap::core::RegistrationOptions{});
      if (s.ok()) {
        evermap::core::StereoMatchPair m = evermap::core::matchPair(previous, kf, s);
        for (auto& x : m.uvd_a) x.z() += offset_px;
        for (auto& x : m.uvd_b) x.z() += offset_px;
        pairs->push_back(std::move(m));
      }
    }
    previous = std::move(kf);
  }
  return 0;
}

// 5. Without ground truth: the disparity offset under which consecutive frames register best.
// A wrong offset distorts each frame's points projectively (far points most), and no rigid
// motion maps one distorted frame onto the next; a wrong baseline only scales them.
int selfCalibrate(const evermap::datasets::KittiSequence& seq, const Rig& rig, double offset_px) {
  auto camera =
      evermap::core::StereoCamera::create(rig.f, rig.fy, rig.cx, rig.cy, rig.B, 1241, 376);
  std::vector<evermap::core::StereoMatchPair> pairs;
  if (registeredPairs(seq, rig, offset_px, &camera, &pairs) != 0) return 1;
  const auto est = evermap::core::estimateDisparityOffset(*camera, pairs,
                                                          evermap::core::DisparityOffsetOptions{});
  if (!est) {
    std::fprintf(stderr, "evermap-stereo-check: %s\n", est.error().message.c_str());
    return 1;
  }
  std::printf(
      "self-calibration: %d of %zu consecutive pairs registered (ORB, registerFrames), %d "
      "inliers\n",
      est->pairs, seq.frames.size() - 1, est->matches);
  std::printf("  cost against offset:");
  for (const auto& [d, c] : est->curve) std::printf(" %+.1f:%.0f", d, c);
  // With the row slope: the same pairs, the offset at each of 13 slopes 0.0015 px per row apart.
  std::vector<double> slopes;
  for (int i = -6; i <= 6; ++i) slopes.push_back(0.0015 * i);
  const auto plane = evermap::core::estimateDisparityPlane(
      *camera, pairs, evermap::core::DisparityOffsetOptions{}, slopes);
  // Its spread: the same from each half of the sequence.
  const size_t half = pairs.size() / 2;
  const std::vector<evermap::core::StereoMatchPair> first(pairs.begin(),
                                                          pairs.begin() + long(half)),
      second(pairs.begin() + long(half), pairs.end());
  if (plane) {
    std::printf(
        "\nwith a row slope (d = measured + offset + slope (v - cy)): offset %+.2f px, slope "
        "%+.5f px per row",
        plane->offset_px, plane->row_slope);
    for (const auto* part : {&first, &second}) {
      const auto p = evermap::core::estimateDisparityPlane(
          *camera, *part, evermap::core::DisparityOffsetOptions{}, slopes);
      std::printf("; %s half %+.2f px, %+.5f", part == &first ? "first" : "second",
                  p ? p->offset_px : std::nan(""), p ? p->row_slope : std::nan(""));
    }
  }
  const auto e1 = evermap::core::estimateDisparityOffset(*camera, first,
                                                         evermap::core::DisparityOffsetOptions{});
  const auto e2 = evermap::core::estimateDisparityOffset(*camera, second,
                                                         evermap::core::DisparityOffsetOptions{});
  std::printf(
      "\ndisparity offset from the images alone: %+.2f px [true = measured + offset%s]; "
      "first half of the pairs %+.2f, second half %+.2f\n",
      est->offset_px, offset_px != 0.0 ? ", after --disparity-offset" : "",
      e1 ? e1->offset_px : std::nan(""), e2 ? e2->offset_px : std::nan(""));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CheckArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  const CheckOptions& o = a.options;
  evermap::datasets::KittiSequenceOptions seq_options;
  seq_options.rate_hz = 10.0;
  seq_options.left_folder = a.left;
  seq_options.right_folder = a.right;
  seq_options.poses = a.poses;
  const auto seq = evermap::datasets::readKittiSequence(a.sequence, seq_options);
  if (!seq) {
    std::fprintf(stderr, "evermap-stereo-check: %s\n", seq.error().message.c_str());
    return 1;
  }
  const Rig rig = printCalibration(*seq);
  evermap::core::StereoDepth::Options depth_options;
  depth_options.max_disparity_px = 160;
  const evermap::core::StereoDepth depth(depth_options);
  Tallies t;
  std::printf(
      "\nper frame (every %d-th): road plane d = a (u - cx) + b (v - cy) + c, height B / |(a, b, "
      "c/f)|%s\n",
      o.step, seq->poses.empty() ? "" : "; offset: ground truth's positions ahead on the plane");
  std::printf("%6s %8s %8s %8s %7s %6s %8s %8s %9s\n", "frame", "rows dy", "a", "b", "c", "points",
              "rms px", "h m", "offset px");
  for (size_t k = 0; k < seq->frames.size(); k += o.step) {
    if (checkFrame(*seq, seq->frames[k], rig, depth, o, &t) != 0) return 1;
  }
  printRectification(t);
  printRoadPlane(t, rig, o.height_m);
  if (o.self_offset && selfCalibrate(*seq, rig, o.offset_px) != 0) return 1;
  if (!t.offsets.empty()) {
    std::printf(
        "disparity offset from the ground truth's direction: median %+.2f px (p10 %+.2f, p90 "
        "%+.2f; %zu frames)"
        " [true = measured + offset%s]\n",
        median(t.offsets), quantile(t.offsets, 0.1), quantile(t.offsets, 0.9), t.offsets.size(),
        o.offset_px != 0.0 ? ", after --disparity-offset" : "");
  }
  return 0;
}
