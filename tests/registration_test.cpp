// core/registration: clique inliers, bidirectional motion estimation (Jacobian, accuracy,
// covariance), ORB matching, registerFrames on synthetic keyframes, rotation from images.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/registration/clique_inliers.h"
#include "core/registration/descriptor_matcher.h"
#include "core/registration/frame_registration.h"
#include "core/registration/motion_estimation.h"
#include "core/registration/rotation_estimation.h"

namespace evermap::core {
namespace {

StereoCamera camera() { return *StereoCamera::create(436.0, 436.0, 376.0, 240.0, 0.11, 752, 480); }

// Points in front of both cameras of a_T_b, seen in both images.
std::vector<Vec3> pointsSeenByBoth(const SE3d& a_T_b, int n, std::mt19937* rng) {
  const StereoCamera cam = camera();
  std::uniform_real_distribution<double> u(0.0, 752.0), v(0.0, 480.0), z(1.0, 8.0);
  std::vector<Vec3> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 p_a = *cam.backProject(Vec3(u(*rng), v(*rng), cam.disparityFromDepth(z(*rng))));
    const auto uvd_b = cam.project(a_T_b.inverse() * p_a);
    if (uvd_b && cam.inImage(uvd_b->x(), uvd_b->y())) out.push_back(p_a);
  }
  return out;
}

// Noisy stereo measurements of p_a in both frames: pixel noise sigma_px on u, v and d.
Correspondence measure(const SE3d& a_T_b, const Vec3& p_a, double sigma_px, std::mt19937* rng) {
  const StereoCamera cam = camera();
  std::normal_distribution<double> n(0.0, sigma_px);
  const Vec3 uvd_a = *cam.project(p_a) + Vec3(n(*rng), n(*rng), n(*rng));
  const Vec3 uvd_b = *cam.project(a_T_b.inverse() * p_a) + Vec3(n(*rng), n(*rng), n(*rng));
  return {uvd_a.head<2>(), *cam.backProject(uvd_a), uvd_b.head<2>(), *cam.backProject(uvd_b)};
}

const SE3d kMotion(SO3d::exp(Vec3(0.02, -0.15, 0.03)), Vec3(0.12, -0.03, 0.25));

// Noisy measurements (sigma_px) of n points that both frames of kMotion see.
std::vector<Correspondence> noisyMatches(int n, double sigma_px, std::mt19937* rng) {
  std::vector<Correspondence> matches;
  for (const Vec3& p : pointsSeenByBoth(kMotion, n, rng)) {
    matches.push_back(measure(kMotion, p, sigma_px, rng));
  }
  return matches;
}

// 0, 1, ..., n - 1: every candidate.
std::vector<int> allIndices(size_t n) {
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  return all;
}

TEST(CliqueInliers, FindsTheRigidSubsetAmongOutliers) {
  std::mt19937 rng(1);
  const std::vector<Vec3> pa = pointsSeenByBoth(kMotion, 80, &rng);
  std::vector<Vec3> a, b;
  for (const Vec3& p : pa) {
    a.push_back(p);
    b.push_back(kMotion.inverse() * p);
  }
  // 40 outliers: wrong partners anywhere in the room.
  std::uniform_real_distribution<double> any(-3.0, 3.0);
  for (int i = 0; i < 40; ++i) {
    a.push_back(Vec3(any(rng), any(rng), 4.0 + any(rng)));
    b.push_back(Vec3(any(rng), any(rng), 4.0 + any(rng)));
  }
  const std::vector<int> clique = maxConsistentClique(a, b, {}, {}, CliqueOptions{});
  // Every true match, and at most a stray outlier that happens to fit.
  int inliers = 0;
  for (int i : clique) inliers += i < 80 ? 1 : 0;
  EXPECT_EQ(inliers, 80);
  EXPECT_LE(clique.size(), 82u);
  EXPECT_TRUE(std::is_sorted(clique.begin(), clique.end()));
  EXPECT_TRUE(maxConsistentClique({}, {}, {}, {}, CliqueOptions{}).empty());
}

TEST(CliqueInliers, DepthNoiseIsAllowedForAlongTheRaysOnly) {
  // Far stereo points: depth sigma 0.5 m at 30 m. A depth error (along the ray) of a pair
  // seen one behind the other changes its distance by the full error; the same pair seen side
  // by side keeps its distance, so there a 0.5 m change is not noise but a wrong match.
  CliqueOptions options;  // 0.1 m + 3 sigmas
  const std::vector<double> s = {0.5, 0.5};
  auto consistent = [&](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    return maxConsistentClique(a, b, s, s, options).size() == 2;
  };
  // One behind the other, on the optical axis: 1 sigma of depth error is consistent.
  EXPECT_TRUE(consistent({Vec3(0, 0, 20), Vec3(0, 0, 30)}, {Vec3(0, 0, 20), Vec3(0, 0, 30.5)}));
  // Side by side at 30 m: the same 0.5 m change, across the rays, is not.
  EXPECT_FALSE(consistent({Vec3(-2, 0, 30), Vec3(2, 0, 30)}, {Vec3(-2, 0, 30), Vec3(2.5, 0, 30)}));
  // ... while a 0.5 m depth error of one of them, which moves it along its own ray, is.
  const Vec3 moved = Vec3(2, 0, 30) * (30.5 / 30.0);
  EXPECT_TRUE(consistent({Vec3(-2, 0, 30), Vec3(2, 0, 30)}, {Vec3(-2, 0, 30), moved}));
  // Without sigmas: FOVIS's fixed threshold refuses the depth error too.
  EXPECT_EQ(maxConsistentClique({Vec3(0, 0, 20), Vec3(0, 0, 30)},
                                {Vec3(0, 0, 20), Vec3(0, 0, 30.5)}, {}, {}, options)
                .size(),
            1u);
}

TEST(MotionEstimation, JacobianMatchesNumericalDerivatives) {
  std::mt19937 rng(2);
  const StereoCamera cam = camera();
  const Vec3 p = pointsSeenByBoth(kMotion, 1, &rng).front();
  const Correspondence m = measure(kMotion, p, 0.5, &rng);
  const SE3d T =
      kMotion * SE3d::exp((Vec6() << 0.01, -0.02, 0.01, 0.003, 0.002, -0.004).finished());
  Eigen::Matrix<double, 4, 1> r0;
  Eigen::Matrix<double, 4, 6> J;
  ASSERT_TRUE(bidirectionalResidual(cam, cam, m, T, &r0, &J));
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Vec6 d = Vec6::Zero();
    d(k) = h;
    Eigen::Matrix<double, 4, 1> rp, rm;
    ASSERT_TRUE(bidirectionalResidual(cam, cam, m, T * SE3d::exp(d), &rp, nullptr));
    ASSERT_TRUE(bidirectionalResidual(cam, cam, m, T * SE3d::exp(-d), &rm, nullptr));
    const Eigen::Matrix<double, 4, 1> numeric = (rp - rm) / (2 * h);
    EXPECT_LT((numeric - J.col(k)).norm(), 1e-4 * (1.0 + J.col(k).norm())) << "column " << k;
  }
}

TEST(MotionEstimation, RecoversTheMotionAndRejectsOutliers) {
  std::mt19937 rng(3);
  const StereoCamera cam = camera();
  std::vector<Correspondence> matches = noisyMatches(150, 0.3, &rng);
  // Ten matches whose current observation is off by 5 px: the clique would keep them (small
  // 3-D errors) but the reprojection test must not.
  for (int i = 0; i < 10; ++i) matches[static_cast<size_t>(i)].uv_b += Eigen::Vector2d(5.0, -4.0);
  const std::vector<int> all = allIndices(matches.size());
  const MotionEstimate e = estimateMotion(cam, cam, matches, all, SE3d(), MotionOptions{});
  ASSERT_TRUE(e.ok()) << e.message;
  const SE3d err = kMotion.inverse() * e.a_T_b;
  EXPECT_LT(err.translation().norm(), 0.01);
  EXPECT_LT(rotationAngle(err.so3()), 0.002);
  // All the shifted ones out; a few true ones may exceed 2 px (far points, noisy depth).
  EXPECT_GE(e.inliers.size(), 130u);
  for (int i : e.inliers) EXPECT_GE(i, 10);
  EXPECT_LT(e.mean_reprojection_px, 1.0);
  // Too few candidates, and a degenerate set: statuses, not crashes.
  EXPECT_EQ(estimateMotion(cam, cam, matches, {20, 21, 22}, SE3d(), MotionOptions{}).status,
            MotionStatus::kInsufficientInliers);
  std::vector<Correspondence> same(20, matches[50]);
  std::vector<int> idx(20);
  for (int i = 0; i < 20; ++i) idx[static_cast<size_t>(i)] = i;
  EXPECT_FALSE(estimateMotion(cam, cam, same, idx, SE3d(), MotionOptions{}).ok());
}

TEST(MotionEstimation, GrossOutliersThatPullTheFirstSolveOffAreShedOverSeveralRounds) {
  // A fifth of the candidates 30-60 px off (a clique that admitted far points with wrong
  // depths): the first least-squares solve leaves most true matches beyond the 1 px bound,
  // so FOVIS's single rejection keeps too few; the graduated bound (a robust multiple of the
  // median error, shrinking to 1 px) recovers the motion.
  std::mt19937 rng(5);
  const StereoCamera cam = camera();
  std::vector<Correspondence> matches = noisyMatches(120, 0.2, &rng);
  std::uniform_real_distribution<double> off(30.0, 60.0);
  for (int i = 0; i < 30; ++i) {
    matches[static_cast<size_t>(i)].uv_b += Eigen::Vector2d(off(rng), -off(rng));
    matches[static_cast<size_t>(i)].uv_a += Eigen::Vector2d(-off(rng), off(rng));
  }
  const std::vector<int> all = allIndices(matches.size());
  MotionOptions options;
  options.inlier_max_reprojection_px = 1.0;
  options.max_rejection_rounds = 4;
  const MotionEstimate e = estimateMotion(cam, cam, matches, all, SE3d(), options);
  ASSERT_TRUE(e.ok()) << e.message;
  const SE3d err = kMotion.inverse() * e.a_T_b;
  EXPECT_LT(err.translation().norm(), 0.01);
  for (int i : e.inliers) EXPECT_GE(i, 30);
  EXPECT_GE(e.inliers.size(), 80u);
  options.max_rejection_rounds = 0;
  const MotionEstimate single = estimateMotion(cam, cam, matches, all, SE3d(), options);
  EXPECT_FALSE(single.ok()) << "the case no longer needs the graduated bound";
}

TEST(MotionEstimation, WhiteningForDepthNoiseKeepsFarPointsWithinTheBound) {
  // Far points (20-60 m at 0.11 m baseline: ~1-2.5 px disparity) with 0.3 px disparity noise,
  // under a 1 m forward motion: their depth errors move their reprojections by pixels along
  // the epipolar direction. Unwhitened, most fall beyond a 1 px bound; whitened for that
  // noise, the motion is estimated from most of them and no worse.
  std::mt19937 rng(6);
  const StereoCamera cam = camera();
  const SE3d forward(SO3d::exp(Vec3(0.0, 0.01, 0.0)), Vec3(0.05, 0.0, 1.0));
  std::uniform_real_distribution<double> u(40.0, 712.0), v(40.0, 440.0), z(20.0, 60.0);
  std::vector<Correspondence> matches;
  while (matches.size() < 150) {
    const Vec3 p_a = *cam.backProject(Vec3(u(rng), v(rng), cam.disparityFromDepth(z(rng))));
    const auto uvd_b = cam.project(forward.inverse() * p_a);
    if (!uvd_b || !cam.inImage(uvd_b->x(), uvd_b->y())) continue;
    std::normal_distribution<double> px(0.0, 0.1), disp(0.0, 0.3);
    const Vec3 a = *cam.project(p_a) + Vec3(px(rng), px(rng), disp(rng));
    const Vec3 b = *uvd_b + Vec3(px(rng), px(rng), disp(rng));
    const auto pa = cam.backProject(a), pb = cam.backProject(b);
    if (!pa || !pb || a.z() <= 0.2 || b.z() <= 0.2) continue;
    matches.push_back({a.head<2>(), *pa, b.head<2>(), *pb});
  }
  const std::vector<int> all = allIndices(matches.size());
  MotionOptions options;
  options.inlier_max_reprojection_px = 1.0;
  options.max_mean_reprojection_px = 10.0;
  options.use_initial_guess = true;
  const MotionEstimate plain = estimateMotion(cam, cam, matches, all, forward, options);
  options.disparity_sigma_px = 0.3;
  const MotionEstimate whitened = estimateMotion(cam, cam, matches, all, forward, options);
  ASSERT_TRUE(whitened.ok()) << whitened.message;
  std::printf("inliers: %zu unwhitened, %zu whitened\n", plain.inliers.size(),
              whitened.inliers.size());
  EXPECT_GT(whitened.inliers.size(), 2 * plain.inliers.size());
  EXPECT_LT(rotationAngle((forward.inverse() * whitened.a_T_b).so3()), 0.002);
}

TEST(MotionEstimation, CovarianceMatchesTheSpreadOfTheEstimates) {
  std::mt19937 rng(4);
  const StereoCamera cam = camera();
  const std::vector<Vec3> points = pointsSeenByBoth(kMotion, 60, &rng);
  const std::vector<int> all = allIndices(points.size());
  std::vector<Vec6> errors;
  Mat6 predicted = Mat6::Zero();
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    std::vector<Correspondence> matches;
    for (const Vec3& p : points) matches.push_back(measure(kMotion, p, 0.5, &rng));
    MotionOptions o;
    o.pixel_sigma_px = 0.01;  // let the residuals speak
    o.inlier_max_reprojection_px = 10.0;
    o.max_mean_reprojection_px = 10.0;
    const MotionEstimate e = estimateMotion(cam, cam, matches, all, SE3d(), o);
    ASSERT_TRUE(e.ok()) << e.message;
    errors.push_back((kMotion.inverse() * e.a_T_b).log());
    predicted += e.covariance / trials;
  }
  Mat6 empirical = Mat6::Zero();
  for (const Vec6& e : errors) empirical += e * e.transpose() / trials;
  // Per axis, the predicted standard deviation is within a factor 2 of the observed one
  // (first-order, and the two directions share their measurements).
  for (int k = 0; k < 6; ++k) {
    const double ratio = std::sqrt(predicted(k, k) / empirical(k, k));
    EXPECT_GT(ratio, 0.5) << "axis " << k;
    EXPECT_LT(ratio, 2.0) << "axis " << k;
  }
}

TEST(DescriptorMatcher, KeepsMutualBestMatchesOnly) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255);
  auto random = [&] {
    OrbDescriptor d;
    for (auto& b : d) b = static_cast<uint8_t>(byte(rng));
    return d;
  };
  std::vector<OrbDescriptor> a(50), b;
  for (auto& d : a) d = random();
  // b[i] = a[i] with 10 bits flipped, in reverse order, plus unrelated descriptors.
  for (int i = 49; i >= 0; --i) {
    OrbDescriptor d = a[static_cast<size_t>(i)];
    for (int k = 0; k < 10; ++k)
      d[static_cast<size_t>(k * 3)] ^= static_cast<uint8_t>(1 << (k % 8));
    b.push_back(d);
  }
  for (int i = 0; i < 50; ++i) b.push_back(random());
  const auto m = matchDescriptors(a, b, DescriptorMatchOptions{});
  ASSERT_EQ(m.size(), 50u);
  for (const auto& [i, j] : m) EXPECT_EQ(j, 49 - i);
  // Two identical candidates: the ratio test refuses the ambiguity.
  std::vector<OrbDescriptor> twice = {a[0], a[0]};
  EXPECT_TRUE(matchDescriptors({a[0]}, twice, DescriptorMatchOptions{}).empty());
}

// A keyframe of points seen from the origin and its counterpart from a_T_b, with shared
// random descriptors (slightly perturbed) and a share of unrelated features.
std::pair<KeyframeFeatures, KeyframeFeatures> keyframePair(const SE3d& a_T_b, int n, int outliers,
                                                           std::mt19937* rng) {
  const StereoCamera cam = camera();
  std::uniform_int_distribution<int> byte(0, 255);
  KeyframeFeatures a, b;
  auto add = [&](KeyframeFeatures* k, const Correspondence& m, bool first, const OrbDescriptor& d) {
    const Eigen::Vector2d uv = first ? m.uv_a : m.uv_b;
    const Vec3 p = first ? m.p_a : m.p_b;
    k->keypoints.push_back(uv.cast<float>());
    k->points.push_back(p.cast<float>());
    k->disparity.push_back(static_cast<float>(cam.disparityFromDepth(p.z())));
    k->levels.push_back(0);
    k->descriptors.push_back(d);
  };
  const std::vector<Vec3> points = pointsSeenByBoth(a_T_b, n + outliers, rng);
  for (int i = 0; i < n + outliers; ++i) {
    OrbDescriptor d;
    for (auto& x : d) x = static_cast<uint8_t>(byte(*rng));
    const Correspondence m = measure(a_T_b, points[static_cast<size_t>(i)], 0.3, rng);
    add(&a, m, true, d);
    if (i >= n) {  // an outlier: same descriptor, but its partner in b is another point
      const Correspondence o = measure(a_T_b, points[static_cast<size_t>((i + 7) % n)], 0.3, rng);
      add(&b, o, false, d);
    } else {
      d[0] ^= 0x5;
      add(&b, m, false, d);
    }
  }
  return {a, b};
}

TEST(RegisterFrames, RecoversTheMotionBetweenKeyframesWithOutliers) {
  std::mt19937 rng(6);
  const auto [a, b] = keyframePair(kMotion, 120, 60, &rng);
  const RegistrationSummary s = registerFrames(camera(), a, camera(), b, RegistrationOptions{});
  ASSERT_TRUE(s.ok()) << s.message;
  EXPECT_EQ(s.num_features_a, 180);
  EXPECT_EQ(s.num_matches, 180);
  EXPECT_GE(s.num_inliers, 110);
  EXPECT_LE(s.num_clique, 125);
  const SE3d err = kMotion.inverse() * s.a_T_b;
  EXPECT_LT(err.translation().norm(), 0.01);
  EXPECT_LT(rotationAngle(err.so3()), 0.002);
  for (const auto& [i, j] : s.inliers) EXPECT_EQ(i, j);  // matches of the same point
  EXPECT_GT(s.covariance.diagonal().minCoeff(), 0.0);
}

TEST(RegisterFrames, ReportsBadInputTooFewFeaturesAndUnrelatedFrames) {
  std::mt19937 rng(7);
  auto [a, b] = keyframePair(kMotion, 120, 0, &rng);
  // Unrelated: b's descriptors shuffled against its points.
  KeyframeFeatures shuffled = b;
  std::shuffle(shuffled.points.begin(), shuffled.points.end(), rng);
  EXPECT_EQ(registerFrames(camera(), a, camera(), shuffled, RegistrationOptions{}).status,
            RegistrationStatus::kInsufficientInliers);
  KeyframeFeatures few = a;
  for (auto* v : {&few.keypoints}) v->resize(10);
  few.points.resize(10);
  few.disparity.resize(10);
  few.levels.resize(10);
  few.descriptors.resize(10);
  EXPECT_EQ(registerFrames(camera(), few, camera(), b, RegistrationOptions{}).status,
            RegistrationStatus::kInsufficientFeatures);
  KeyframeFeatures broken = a;
  broken.points[3].z() = std::nanf("");
  const RegistrationSummary s =
      registerFrames(camera(), broken, camera(), b, RegistrationOptions{});
  EXPECT_EQ(s.status, RegistrationStatus::kBadInput);
  EXPECT_NE(s.message.find("feature 3"), std::string::npos) << s.message;
  broken = a;
  broken.levels.pop_back();
  EXPECT_EQ(registerFrames(camera(), broken, camera(), b, RegistrationOptions{}).status,
            RegistrationStatus::kBadInput);
  RegistrationOptions bad;
  bad.min_inliers = 2;
  EXPECT_EQ(registerFrames(camera(), a, camera(), b, bad).status, RegistrationStatus::kBadInput);
}

// A textured image and the same seen from a camera turned by R (x_b = K R K⁻¹ x_a), both at
// the top level of a 4-level pyramid (94x60), as odometry uses them.
std::pair<cv::Mat, cv::Mat> topLevelViews(const StereoCamera& cam, const SO3d& R) {
  cv::Mat noise(480, 752, CV_8UC1);
  cv::RNG rng(8);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat a;
  cv::GaussianBlur(noise, a, cv::Size(0, 0), 4.0);
  cv::normalize(a, a, 0, 255, cv::NORM_MINMAX);
  const Eigen::Matrix3d K =
      (Eigen::Matrix3d() << cam.fx(), 0, cam.cx(), 0, cam.fy(), cam.cy(), 0, 0, 1).finished();
  const Eigen::Matrix3d H = K * R.matrix() * K.inverse();
  cv::Mat Hcv(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) Hcv.at<double>(i, j) = H(i, j);
  }
  cv::Mat b;
  cv::warpPerspective(a, b, Hcv, a.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  for (int l = 0; l < 3; ++l) {
    cv::pyrDown(a, a);
    cv::pyrDown(b, b);
  }
  return {a, b};
}

TEST(RotationEstimation, RecoversTheRotationBetweenTwoViews) {
  const StereoCamera cam = camera();
  const SO3d R = SO3d::exp(Vec3(0.01, -0.03, 0.02));
  const auto [a3, b3] = topLevelViews(cam, R);
  const auto est = estimateRotation(a3, b3, cam, 3, RotationEstimateOptions{});
  ASSERT_TRUE(est.has_value());
  EXPECT_LT(rotationAngle(R.inverse() * *est), 0.003);  // 0.17°: well inside a search window
  // Unrelated or flat images: no estimate rather than a wrong one.
  const cv::Mat flat(60, 94, CV_8UC1, cv::Scalar(80));
  EXPECT_FALSE(estimateRotation(flat, flat, cam, 3, RotationEstimateOptions{}).has_value());
  EXPECT_FALSE(estimateRotation(a3, cv::Mat(), cam, 3, RotationEstimateOptions{}).has_value());
}

TEST(RotationEstimation, AFastTurnOutsideTheBasinIsRecoveredFromAPredictedRotation) {
  // Frames lost during a turn: the turn between the two views left the photometric basin
  // around the identity, and a prediction (the last motion at the same velocity) brings it
  // back.
  const StereoCamera cam = camera();
  const SO3d R = SO3d::exp(Vec3(0.02, 0.22, 0.01));
  const auto [a3, b3] = topLevelViews(cam, R);
  const auto from_identity = estimateRotation(a3, b3, cam, 3, RotationEstimateOptions{});
  EXPECT_TRUE(!from_identity.has_value() || rotationAngle(R.inverse() * *from_identity) > 0.01);
  const SO3d predicted = SO3d::exp(Vec3(0.0, 0.19, 0.0));
  const auto est = estimateRotation(a3, b3, cam, 3, RotationEstimateOptions{}, predicted);
  ASSERT_TRUE(est.has_value());
  EXPECT_LT(rotationAngle(R.inverse() * *est), 0.003);
}

}  // namespace
}  // namespace evermap::core
