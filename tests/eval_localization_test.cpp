// tools/eval/localization_accuracy: the stored map put in the truth's frame by its nodes (also a
// map of one corridor, whose rotation about the corridor the positions leave free), and the
// figures of a localization run against the truth (errors, false frames, false placements).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <numbers>
#include <vector>

#include "tools/eval/localization_accuracy.h"

namespace evermap::eval {
namespace {

core::SE3d yawed(double yaw_rad, const core::Vec3& t) {
  return core::SE3d(core::SO3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, core::Vec3::UnitZ()))),
                    t);
}

// The map's frame: the truth's turned by 30 degrees and moved (truth = T * map).
const core::SE3d kTruthFromMap = yawed(0.5236, core::Vec3(4.0, -2.0, 1.0));

TEST(LocalizationAccuracy, TheMapOfOneCorridorIsPutInTheTruthsFrameRightSideUp) {
  // Nodes along one corridor, 1 mm off its line to one side in the map and to the other in
  // the truth (each its own small error): the positions fit best turned 180 degrees about the
  // corridor, the first node's orientation says it is right side up.
  std::vector<core::SE3d> map_nodes, true_nodes;
  for (int i = 0; i < 8; ++i) {
    const double across = 0.001 * ((i * 7) % 3 - 1);
    map_nodes.push_back(yawed(0.0, core::Vec3(1.5 * i, across, 0.0)));
    true_nodes.push_back(kTruthFromMap * yawed(0.0, core::Vec3(1.5 * i, -across, 0.0)));
  }
  auto truth_S_map = mapToTruth(map_nodes, true_nodes);
  ASSERT_TRUE(truth_S_map.ok()) << truth_S_map.error().message;
  const core::SE3d off = kTruthFromMap.inverse() * truth_S_map->rigid;
  EXPECT_LT(off.translation().norm(), 0.0025);
  EXPECT_LT(Eigen::AngleAxisd(off.quaternion()).angle(), 1e-6);
}

TEST(LocalizationAccuracy, ASpreadMapIsFittedByItsPositions) {
  std::vector<core::SE3d> map_nodes, true_nodes;
  for (int i = 0; i < 6; ++i) {
    const core::SE3d node =
        yawed(0.3 * i, core::Vec3(2.0 * std::cos(i), 3.0 * std::sin(i), 0.1 * i));
    map_nodes.push_back(node);
    // Orientations that disagree do not move a fit of positions.
    true_nodes.push_back(kTruthFromMap * node * yawed(0.1, core::Vec3::Zero()));
  }
  auto truth_S_map = mapToTruth(map_nodes, true_nodes);
  ASSERT_TRUE(truth_S_map.ok());
  EXPECT_LT((truth_S_map->rigid.translation() - kTruthFromMap.translation()).norm(), 1e-9);
  EXPECT_FALSE(mapToTruth({}, {}).ok());
  EXPECT_FALSE(mapToTruth(map_nodes, {}).ok());
}

// Ten frames 0.1 s apart, 0.5 m apart along the map's x axis: the map's poses (the truth's are
// kTruthFromMap times them).
struct StraightRun {
  std::vector<int64_t> utimes;
  std::vector<core::SE3d> bodies;
  std::map<int64_t, core::SE3d> truth;
  StraightRun() {
    for (int i = 0; i < 10; ++i) {
      utimes.push_back(1000000 + 100000 * i);
      bodies.push_back(yawed(0.0, core::Vec3(0.5 * i, 0.0, 0.0)));
      truth[utimes.back()] = kTruthFromMap * bodies.back();
    }
  }
};

TEST(LocalizationAccuracy, FalseFramesAndFalsePlacementsAreCountedOverTheLocalizedOnes) {
  const StraightRun run;
  const std::map<int64_t, core::SE3d>& truth = run.truth;
  std::vector<LocalizedPose> poses;
  for (int i = 0; i < 10; ++i) {
    const int64_t utime = run.utimes[i];
    const core::SE3d& body = run.bodies[i];
    LocalizedPose p{utime, i >= 2, i >= 2, body};
    // Frames 2-3: 0.1 m off; 4: not localized; 5-6: placed again 0.8 m off (a false
    // placement); 7-9: right.
    if (i == 2 || i == 3) p.world_T_body = yawed(0.0, body.translation() + core::Vec3(0, 0.1, 0));
    if (i == 4) p.localized = false;
    if (i == 5 || i == 6) p.world_T_body = yawed(0.0, body.translation() + core::Vec3(0, 0.8, 0));
    poses.push_back(p);
  }
  const LocalizationAccuracy a =
      evaluateLocalization(poses, core::Similarity{1.0, kTruthFromMap}, truth, {}, 0.5, 5.0);
  EXPECT_EQ(a.poses, 10);
  EXPECT_EQ(a.localized, 7);
  EXPECT_NEAR(a.first_localized_s, 0.2, 1e-9);
  EXPECT_EQ(a.poses_with_truth, 7);
  EXPECT_EQ(a.false_poses, 2);
  EXPECT_EQ(a.false_placements, 1);
  EXPECT_NEAR(a.ate_max_m, 0.8, 1e-9);
  EXPECT_NEAR(a.ate_rmse_m, std::sqrt((2 * 0.01 + 2 * 0.64) / 7.0), 1e-9);
  EXPECT_NEAR(poses[4].error_m, 0.0, 1e-9);  // placed, not localized: its error, not counted
  EXPECT_EQ(poses[0].error_m, -1);           // never placed: no error
  EXPECT_EQ(a.node_poses, 0);                // no node given: no figures against one
  EXPECT_EQ(a.node_false_poses, -1);
}

TEST(LocalizationAccuracy, AgainstTheNodeTrackedTheMapsOwnErrorIsLeftOut) {
  // The map: node 3 is stored 8 degrees off its true orientation and 0.6 m off its place (the
  // map's own error); node 4 is stored right. The robot is tracked against node 3 at frames
  // 0-3, right relative to it; frame 4 is not localized; at frames 5-9 it is tracked against
  // node 4, placed 6 degrees off (frame 5 only) and dead reckoning 0.12 m further off a frame.
  const std::map<int64_t, StoredNodeTruth> nodes = {
      {3,
       {yawed(0.1396, core::Vec3(0.6, 0.0, 0.0)), kTruthFromMap * yawed(0.0, core::Vec3::Zero())}},
      {4,
       {yawed(0.0, core::Vec3(5.0, 0.0, 0.0)), kTruthFromMap * yawed(0.0, core::Vec3(5.0, 0, 0))}},
  };
  const StraightRun run;
  const std::map<int64_t, core::SE3d>& truth = run.truth;
  std::vector<LocalizedPose> poses;
  for (int i = 0; i < 10; ++i) {
    const int64_t utime = run.utimes[i];
    const int64_t node = i < 5 ? 3 : 4;
    const core::SE3d node_T_body = nodes.at(node).truth_T_node.inverse() * truth.at(utime);
    const double drift = i < 5 ? 0.0 : 0.12 * (i - 4);
    const double yaw = i == 5 ? 6.0 * std::numbers::pi / 180.0 : 0.0;
    poses.push_back(
        {utime, true, i != 4,
         nodes.at(node).world_T_node * node_T_body * yawed(yaw, core::Vec3(0, drift, 0)), node});
  }
  const LocalizationAccuracy a =
      evaluateLocalization(poses, core::Similarity{1.0, kTruthFromMap}, truth, nodes, 0.5, 5.0);
  // Against the truth: frames 0-3 are false (8 degrees, the map's), 5 (6 degrees) and 9 (0.6 m)
  // too; both placements (0 and 5) are false.
  EXPECT_EQ(a.false_poses, 6);
  EXPECT_EQ(a.false_placements, 2);
  // Against the node: only frames 5 and 9, and only the placement at 5.
  EXPECT_EQ(a.node_poses, 9);
  EXPECT_EQ(a.node_false_poses, 2);
  EXPECT_EQ(a.node_false_placements, 1);
  EXPECT_NEAR(a.node_rmse_m, 0.12 * std::sqrt((1 + 4 + 9 + 16 + 25) / 9.0), 1e-9);
  EXPECT_NEAR(a.node_rot_rmse_deg, std::sqrt(36.0 / 9.0), 1e-6);
  // A pose naming a node the map does not have is left out of the node figures.
  poses[9].node = 99;
  EXPECT_EQ(
      evaluateLocalization(poses, core::Similarity{1.0, kTruthFromMap}, truth, nodes, 0.5, 5.0)
          .node_poses,
      8);
}

}  // namespace
}  // namespace evermap::eval
