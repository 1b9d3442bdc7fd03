// The end-of-run map evaluation (tools/pipeline-eval/map_evaluation.h) on a written simulated run:
// a map made of the true poses, moved rigidly, scores zero; a displaced node shows up in the
// ATE; floors and sessions are counted against the sidecar; bad inputs name the file.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "tests/scratch_dir.h"
#include "tests/sim_test_support.h"
#include "tools/pipeline-eval/map_evaluation.h"
#include "tools/sim/run.h"
#include "tools/sim/run_output.h"

namespace evermap::mapper {
namespace {

sim::SimOptions threeFloors() {
  return sim::testing::smallPatrol(3, 1, 0.03, 1, sim::PatrolOptions{}.explore_sessions);
}

TEST(MapEvaluation, ScoresARigidlyMovedTrueMapAsExactAndSeesADisplacedNode) {
  evermap::testing::ScratchDir dir;
  auto plan = sim::RunPlan::create(threeFloors());
  ASSERT_TRUE(plan);
  ASSERT_TRUE(sim::writeRun(*plan, dir.path()));
  auto truth = readRunTruth(dir.path());
  ASSERT_TRUE(truth) << truth.error().message;
  EXPECT_EQ(truth->floors.size(), 3u);
  EXPECT_EQ(truth->sessions, 1);
  ASSERT_GT(truth->world_T_body.size(), 100u);

  // Every 20th truth sample as a node, in a map frame moved by a rigid transform.
  const core::SE3d map_T_world(core::SO3d::exp(core::Vec3(0.0, 0.0, 0.7)),
                               core::Vec3(3.0, -2.0, 0.5));
  EvalMap map;
  int k = 0;
  for (const auto& [utime, pose] : truth->world_T_body) {
    if (k++ % 20) continue;
    map.nodes.push_back(EvalNode{static_cast<int64_t>(map.nodes.size()), utime, map_T_world * pose,
                                 truth->floorAt(pose.translation().z()), 0});
  }
  map.floors = truth->floors;
  map.floors[1] += 1.0;  // one floor of the table at a wrong height
  auto e = evaluateMap(map, *truth);
  ASSERT_TRUE(e) << e.error().message;
  EXPECT_EQ(e->nodes, static_cast<int64_t>(map.nodes.size()));
  EXPECT_EQ(e->nodes_with_truth, e->nodes);
  EXPECT_EQ(e->nodes_floor_right, e->nodes);
  EXPECT_NEAR(e->ate_rmse_m, 0.0, 1e-6);
  EXPECT_EQ(e->floors, 3);
  EXPECT_EQ(e->floors_right, 2);
  EXPECT_EQ(e->sessions, 1);

  // One node 2 m off: the rmse over n nodes is about 2/sqrt(n) after alignment.
  map.nodes[map.nodes.size() / 2].world_T_body =
      core::SE3d(core::SO3d(), core::Vec3(2.0, 0.0, 0.0)) *
      map.nodes[map.nodes.size() / 2].world_T_body;
  auto off = evaluateMap(map, *truth);
  ASSERT_TRUE(off);
  const double n = static_cast<double>(map.nodes.size());
  EXPECT_NEAR(off->ate_rmse_m, 2.0 / std::sqrt(n), 0.5 / std::sqrt(n));
  EXPECT_GT(off->ate_max_m, 1.5);
}

TEST(MapEvaluation, NamesTheFolderOrFileThatIsNotARun) {
  evermap::testing::ScratchDir dir;
  auto missing = readRunTruth(dir.path());
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("run.sim.txt"), std::string::npos);
  std::ofstream(dir.path() / "run.sim.txt") << "seed = 1\n";
  auto no_floors = readRunTruth(dir.path());
  ASSERT_FALSE(no_floors);
  EXPECT_NE(no_floors.error().message.find("meta.floor"), std::string::npos);
  auto no_log = readRecordedRun(dir.path() / "none.lcmlog");
  ASSERT_FALSE(no_log);
  EXPECT_NE(no_log.error().message.find("none.lcmlog"), std::string::npos);
}

}  // namespace
}  // namespace evermap::mapper
