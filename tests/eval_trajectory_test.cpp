// tools/eval/trajectory and association: the readers on small hand-written files and on the
// real KITTI and EuRoC files, the TUM writer, format guessing and time-stamp association.
#include <gtest/gtest.h>

#include <fstream>

#include "eval_synthetic.h"
#include "image_test_util.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/eval/association.h"
#include "tools/eval/trajectory.h"

namespace evermap::eval {
namespace {

namespace fs = std::filesystem;

using TempDir = evermap::testing::ScratchDir;
using evermap::testing::expectError;

TEST(TrajectoryReaders, KittiPosesGetStampsFromTheTimesFileOrTheLineIndex) {
  TempDir dir;
  const auto poses = dir.write("poses.txt",
                               "1 0 0 0 0 1 0 0 0 0 1 0\n"
                               "0 -1 0 1.5 1 0 0 2.5 0 0 1 -0.5\n");
  const auto times = dir.write("times.txt", "0.000000e+00\n1.038752e-01\n");
  const auto by_index = readKitti(poses);
  ASSERT_TRUE(by_index.ok()) << by_index.error().message;
  ASSERT_EQ(by_index->size(), 2u);
  EXPECT_EQ(by_index->poses[1].t_ns, 1000000000LL);
  const core::SE3d& T = by_index->poses[1].world_T_body;
  EXPECT_NEAR((T.translation() - core::Vec3(1.5, 2.5, -0.5)).norm(), 0.0, 1e-12);
  // The rotation is 90 degrees about z: it maps x to y.
  EXPECT_NEAR((T.so3() * core::Vec3::UnitX() - core::Vec3::UnitY()).norm(), 0.0, 1e-12);

  const auto timed = readKitti(poses, times);
  ASSERT_TRUE(timed.ok()) << timed.error().message;
  EXPECT_EQ(timed->poses[1].t_ns, 103875200LL);
}

TEST(TrajectoryReaders, KittiErrorsNameFileAndLine) {
  TempDir dir;
  const auto short_line = dir.write("a.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  auto r = readKitti(short_line);
  expectError(r, "a.txt:2: expected 12 numbers");

  const auto nan_line = dir.write("b.txt", "1 0 0 nan 0 1 0 0 0 0 1 0\n");
  r = readKitti(nan_line);
  expectError(r, "b.txt:1: non-finite");

  const auto not_rotation = dir.write("c.txt", "2 0 0 0 0 1 0 0 0 0 1 0\n");
  r = readKitti(not_rotation);
  expectError(r, "c.txt:1: the 3x3 block is not a rotation");

  const auto good = dir.write("d.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  const auto few_times = dir.write("t.txt", "0.0\n");
  r = readKitti(good, few_times);
  expectError(r, "t.txt: 1 stamps for 2 poses");

  const auto bad_time = dir.write("u.txt", "0.0\nsoon\n");
  r = readKitti(good, bad_time);
  expectError(r, "u.txt:2");

  const auto backwards = dir.write("v.txt", "1.0\n0.5\n");
  r = readKitti(good, backwards);
  expectError(r, "time stamps must increase");
}

TEST(TrajectoryReaders, EmptyFilesAreErrors) {
  TempDir dir;
  const auto empty = dir.write("empty.txt", "# only a comment\n\n");
  for (TrajectoryFormat f : {TrajectoryFormat::kTum, TrajectoryFormat::kKitti}) {
    const auto r = readTrajectory(empty, f);
    expectError(r, "empty.txt: no poses");
  }
  const auto missing = readTum(dir.path() / "missing.txt");
  expectError(missing, "missing.txt: cannot open");
}

TEST(TrajectoryReaders, FormatIsGuessedFromExtensionAndFirstLine) {
  TempDir dir;
  EXPECT_EQ(*guessTrajectoryFormat(dir.write("a.txt", "# c\n1 0 0 0 0 0 0 1\n")),
            TrajectoryFormat::kTum);
  EXPECT_EQ(*guessTrajectoryFormat(dir.write("b.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n")),
            TrajectoryFormat::kKitti);
  EXPECT_EQ(*guessTrajectoryFormat(dir.write("c.csv", "#t,p\n")), TrajectoryFormat::kEuroc);
  EXPECT_EQ(*guessTrajectoryFormat(dir.write("d.log", "1,0,0,0,1,0,0,0\n")),
            TrajectoryFormat::kEuroc);
  const auto unknown = guessTrajectoryFormat(dir.write("e.txt", "1 2 3\n"));
  expectError(unknown, "e.txt:1: cannot tell the format");
  EXPECT_FALSE(parseTrajectoryFormat("g2o").ok());
  EXPECT_EQ(*parseTrajectoryFormat("kitti"), TrajectoryFormat::kKitti);
}

TEST(TrajectoryReaders, TumWriterRoundTripsToTheNanosecond) {
  TempDir dir;
  Trajectory t = testing::syntheticTrajectory(50, 1403715274302140001LL, "synthetic");
  const auto file = dir.path() / "out.txt";
  ASSERT_TRUE(writeTum(t, file).ok());
  const auto back = readTum(file);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), t.size());
  for (size_t k = 0; k < t.size(); ++k) {
    EXPECT_EQ(back->poses[k].t_ns, t.poses[k].t_ns);
    const core::SE3d d = core::between(t.poses[k].world_T_body, back->poses[k].world_T_body);
    EXPECT_LT(d.translation().norm(), 1e-8);
    EXPECT_LT(core::rotationAngle(d.so3()), 1e-8);
  }
  // Nothing is left behind but the file itself.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
  // A folder that does not exist is an error naming the file.
  const auto bad = writeTum(t, dir.path() / "no/such/folder/out.txt");
  expectError(bad, "out.txt");
}

TEST(TrajectoryReaders, ReadTheRealKittiAndEurocFiles) {
  EVERMAP_REQUIRE_DATA(kitti, "kitti07-mono-160");
  const auto k = readKitti(kitti / "poses.txt", kitti / "times.txt");
  ASSERT_TRUE(k.ok()) << k.error().message;
  EXPECT_EQ(k->size(), 160u);
  EXPECT_EQ(k->poses[1].t_ns, 103875200LL);
  EXPECT_NEAR(k->poses[2].world_T_body.translation().z(), 1.857373e-01, 1e-12);
  EXPECT_NEAR(k->pathLengthM(), 90.6, 0.1);  // SOURCE.txt
  EXPECT_EQ(*guessTrajectoryFormat(kitti / "poses.txt"), TrajectoryFormat::kKitti);

  EVERMAP_REQUIRE_DATA(euroc, "euroc-v101-micro");
  const auto csv = readEuroc(euroc / "groundtruth_openvins/V1_01_easy.csv");
  const auto txt = readTum(euroc / "groundtruth_openvins/V1_01_easy.txt");
  ASSERT_TRUE(csv.ok()) << csv.error().message;
  ASSERT_TRUE(txt.ok()) << txt.error().message;
  EXPECT_EQ(csv->size(), 2895u);
  EXPECT_EQ(txt->size(), 2895u);
  EXPECT_EQ(*guessTrajectoryFormat(euroc / "groundtruth_openvins/V1_01_easy.txt"),
            TrajectoryFormat::kTum);
  // The .txt is the .csv rounded to 10 µs stamps and 6 decimals: the same poses.
  const auto pairs = associate(*csv, *txt, {.max_dt_s = 1e-5});
  ASSERT_TRUE(pairs.ok()) << pairs.error().message;
  EXPECT_EQ(pairs->size(), 2895u);
  for (size_t i = 0; i < pairs->size(); ++i) {
    EXPECT_LT((pairs->gt[i].translation() - pairs->est[i].translation()).norm(), 1e-5);
  }
}

TEST(Association, PairsNearestStampsWithinTheLimitAndUsesEachPoseOnce) {
  Trajectory gt{"gt", {}};
  for (int k = 0; k < 10; ++k) gt.poses.push_back({k * 100000000LL, core::SE3d()});
  Trajectory est{"est", {}};
  // 0.105 s and 0.11 s both want gt 0.1 s: the nearer (0.105) wins. -0.05 s, 0.35 s and 2 s
  // have no ground-truth pose within 0.02 s.
  for (int64_t t : {-50000000LL, 5000000LL, 105000000LL, 110000000LL, 350000000LL, 2000000000LL}) {
    est.poses.push_back({t, core::SE3d()});
  }
  const auto a = associate(gt, est, {.max_dt_s = 0.02});
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_EQ(a->size(), 2u);
  EXPECT_EQ(a->gt_index, (std::vector<size_t>{0, 1}));
  EXPECT_EQ(a->est_index, (std::vector<size_t>{1, 2}));
  EXPECT_NEAR(a->max_abs_dt_s, 0.005, 1e-12);
  EXPECT_NEAR(a->mean_abs_dt_s, 0.005, 1e-12);
  EXPECT_EQ(a->est_poses, 6u);
}

TEST(Association, NoOverlapInTimeIsAnErrorNamingBothFiles) {
  const Trajectory gt = testing::syntheticTrajectory(20, 0, "gt.txt");
  const Trajectory est = testing::syntheticTrajectory(20, 50000000000LL, "est.txt");
  const auto a = associate(gt, est);
  ASSERT_NO_FATAL_FAILURE(expectError(a, "est.txt"));
  EXPECT_NE(a.error().message.find("gt.txt"), std::string::npos) << a.error().message;
  EXPECT_NE(a.error().message.find("do not overlap"), std::string::npos) << a.error().message;
}

TEST(Association, InvalidInputsAreErrors) {
  Trajectory gt = testing::syntheticTrajectory(5, 0, "gt.txt");
  const Trajectory empty{"empty.txt", {}};
  EXPECT_FALSE(associate(gt, empty).ok());
  EXPECT_FALSE(associate(gt, gt, {.max_dt_s = -1.0}).ok());
  Trajectory nan = gt;
  nan.source = "nan.txt";
  nan.poses[3].world_T_body = core::SE3d(core::SO3d(), core::Vec3(0, std::nan(""), 0));
  const auto r = associate(gt, nan);
  expectError(r, "nan.txt: pose 3 is not finite");
}

}  // namespace
}  // namespace evermap::eval
