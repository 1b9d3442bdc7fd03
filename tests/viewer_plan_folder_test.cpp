// The viewer's floor plans (viewer/plan_folder.h): evermap-map-export's files read back as
// map_server reads them, hostile files refused by name, a new export picked up.
#include "viewer/plan_folder.h"

#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "tools/map-export/occupancy_grid.h"

namespace evermap::viewer {
namespace {

namespace fs = std::filesystem;

class PlanFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("evermap_plan_folder_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name, std::ios::binary) << text;
  }
  // A room seen from its middle: walls occupied, the inside free, the rest unknown.
  map_export::OccupancyGrid room() {
    map_export::GridOptions o;
    map_export::OccupancyGrid grid(-2.0, -1.0, 60, 40, 0.1);
    map_export::Scan scan;
    scan.camera = core::Vec3(0.5, 0.5, 0.5);
    for (int k = 0; k < 90; ++k) {
      const double a = k * 2.0 * 3.14159265358979 / 90.0;
      scan.points.emplace_back(0.5 + 1.2 * std::cos(a), 0.5 + 1.2 * std::sin(a), 0.6);
    }
    grid.addScan(scan, 0.0, o);
    grid.addScan(scan, 0.0, o);
    return grid;
  }
  fs::path dir_;
};

// The runs of a "plans" text's floor back to cells (as plan_layer.js decodes them).
std::vector<uint8_t> decodeRuns(const std::string& runs) {
  std::vector<uint8_t> cells;
  for (size_t k = 0; k < runs.size();) {
    const uint8_t code = runs[k] == 'o' ? 2 : (runs[k] == 'f' ? 1 : 0);
    size_t n = 0;
    for (++k; k < runs.size() && std::isdigit(static_cast<unsigned char>(runs[k])); ++k)
      n = 10 * n + (runs[k] - '0');
    cells.insert(cells.end(), n, code);
  }
  return cells;
}

TEST_F(PlanFolderTest, ReadsTheExportersPlansCellForCellAsMapServerDoes) {
  const map_export::OccupancyGrid grid = room();
  write("floor-2.pgm", grid.pgm());
  write("floor-2.yaml", grid.yaml("floor-2.pgm"));
  auto plan = readPlan(dir_ / "floor-2.yaml");
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_EQ(plan->floor, 2);
  EXPECT_EQ(plan->width, 60);
  EXPECT_EQ(plan->height, 40);
  EXPECT_DOUBLE_EQ(plan->resolution_m, 0.1);
  EXPECT_NEAR(plan->origin_x, -2.0, 1e-9);
  EXPECT_NEAR(plan->origin_y, -1.0, 1e-9);
  int counts[3] = {0, 0, 0};
  for (int j = 0; j < 40; ++j) {
    for (int i = 0; i < 60; ++i) {
      const uint8_t c = plan->cells[static_cast<size_t>(j) * 60 + i];
      ++counts[c];
      ASSERT_EQ(c, static_cast<uint8_t>(grid.cell(i, j))) << "cell " << i << ", " << j;
    }
  }
  EXPECT_GT(counts[1], 50);  // the room is free inside
  EXPECT_GT(counts[2], 20);  // and walled
  EXPECT_GT(counts[0], 100);
  // The text the page gets holds the same cells.
  const std::string text = plansText({*plan}, dir_.string(), 0);
  const auto at = text.find("\"cells\":\"") + 9;
  EXPECT_EQ(decodeRuns(text.substr(at, text.find('"', at) - at)), plan->cells);
  EXPECT_NE(text.find("\"occupied\":" + std::to_string(counts[2])), std::string::npos);
}

TEST_F(PlanFolderTest, NegatedAndCommentedPlansOfOtherWritersAreRead) {
  // A map_saver-style header comment and negate: 1 (white is occupied).
  write("floor-0.pgm", std::string("P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n3 1\n255\n") +
                           std::string("\xff\x00\xcd", 3));
  write("floor-0.yaml",
        "image: floor-0.pgm\nresolution: 0.05\norigin: [1.0, 2.0, 0.5]\nnegate: 1\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  auto plan = readPlan(dir_ / "floor-0.yaml");
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_EQ(plan->cells, (std::vector<uint8_t>{2, 1, 2}));
  EXPECT_DOUBLE_EQ(plan->origin_yaw, 0.5);
}

TEST_F(PlanFolderTest, AHostilePlanIsRefusedByNameAndTheOthersAreShown) {
  const map_export::OccupancyGrid grid = room();
  write("floor-0.pgm", grid.pgm());
  write("floor-0.yaml", grid.yaml("floor-0.pgm"));
  const std::string good_yaml = grid.yaml("floor-1.pgm");
  struct Case {
    std::string pgm, yaml, why;
  };
  const std::string pgm = grid.pgm();
  const std::vector<Case> cases = {
      {pgm.substr(0, pgm.size() - 7), good_yaml, "bytes of pixels"},
      {"P6\n60 40\n255\n" + pgm.substr(13), good_yaml, "not a binary PGM"},
      {"P5\n60 40\n65535\n" + pgm.substr(13), good_yaml, "malformed PGM header"},
      {"P5\n99999 99999\n255\n", good_yaml, "too large"},
      {pgm, "image: floor-1.pgm\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
       "no resolution"},
      {pgm,
       "image: floor-1.pgm\nresolution: nan\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
       "free_thresh: 0.2\n",
       "is not a finite number"},
      {pgm,
       "image: floor-1.pgm\nresolution: 0.1\norigin: [0, 0]\noccupied_thresh: 0.65\n"
       "free_thresh: 0.2\n",
       "origin is not"},
      {"",
       "image: nowhere.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
       "free_thresh: 0.2\n",
       "nowhere.pgm: cannot be read"},
  };
  for (const Case& c : cases) {
    if (!c.pgm.empty()) write("floor-1.pgm", c.pgm);
    write("floor-1.yaml", c.yaml);
    auto plan = readPlan(dir_ / "floor-1.yaml");
    ASSERT_FALSE(plan) << c.why;
    EXPECT_NE(plan.error().message.find(c.why), std::string::npos) << plan.error().message;
    EXPECT_NE(plan.error().message.find("floor-1."), std::string::npos) << plan.error().message;
    fs::remove(dir_ / "floor-1.pgm");
  }
  // Random bytes as the image never crash the reader.
  std::mt19937 rng(7);
  for (int k = 0; k < 200; ++k) {
    std::string junk = "P5\n";
    for (int b = 0; b < 40; ++b) junk += static_cast<char>(rng() % 256);
    write("floor-1.pgm", junk);
    write("floor-1.yaml", good_yaml);
    (void)readPlan(dir_ / "floor-1.yaml");
  }
  PlanFolder folder(dir_);
  const auto text = folder.poll();
  ASSERT_TRUE(text);
  EXPECT_EQ(folder.refused(), 1);
  EXPECT_NE(text->find("\"floor\":0"), std::string::npos);
  EXPECT_EQ(text->find("\"floor\":1"), std::string::npos);
}

TEST_F(PlanFolderTest, ANewExportIsPickedUpAndAnUnchangedFolderSendsNothing) {
  PlanFolder folder(dir_);
  const auto empty = folder.poll();
  ASSERT_TRUE(empty);  // the first look always says what there is: no floors
  EXPECT_NE(empty->find("\"floors\":[]"), std::string::npos);
  EXPECT_FALSE(folder.poll());
  const map_export::OccupancyGrid grid = room();
  write("floor-0.pgm", grid.pgm());
  write("floor-0.yaml", grid.yaml("floor-0.pgm"));
  const auto first = folder.poll();
  ASSERT_TRUE(first);
  EXPECT_NE(first->find("\"floor\":0"), std::string::npos);
  EXPECT_FALSE(folder.poll());
  // The next export (a loop closure moved the walls): a new origin and size.
  map_export::OccupancyGrid moved(-3.0, -1.0, 70, 40, 0.1);
  write("floor-0.pgm", moved.pgm());
  write("floor-0.yaml", moved.yaml("floor-0.pgm"));
  const auto second = folder.poll();
  ASSERT_TRUE(second);
  EXPECT_NE(second->find("\"width\":70"), std::string::npos);
  EXPECT_EQ(folder.refused(), 0);
}

}  // namespace
}  // namespace evermap::viewer
