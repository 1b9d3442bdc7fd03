// Whole runs on disk: logs per session, TUM ground truth and the sidecar; same seed, same
// bytes; the sidecar regenerates the run; the schedule covers every floor.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include <evermap/pose_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/common/key_value_file.h"
#include "core/messages/channels.h"
#include "sim_test_support.h"
#include "tools/sim/run_output.h"

namespace evermap::sim {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() /
              ("evermap-sim-" + std::to_string(::getpid()) + "-" + name)) {
    fs::remove_all(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

WrittenRun write(const SimOptions& o, const fs::path& dir) {
  auto plan = RunPlan::create(o);
  EXPECT_TRUE(plan.ok());
  auto w = writeRun(*plan, dir);
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().message);
  return std::move(*w);
}

TEST(SimRun, SameSeedGivesIdenticalLogBytes) {
  TempDir a("same-a"), b("same-b"), c("same-c");
  const WrittenRun wa = write(testing::smallRun(21), a.path());
  write(testing::smallRun(21), b.path());
  write(testing::smallRun(22), c.path());
  ASSERT_EQ(wa.logs.size(), 2u);
  for (const char* name : {"session-00.lcmlog", "session-01.lcmlog", "session-00.tum",
                           "session-01.tum", "run.sim.txt"}) {
    const std::string x = readBytes(a.path() / name);
    ASSERT_FALSE(x.empty()) << name;
    EXPECT_TRUE(x == readBytes(b.path() / name))
        << name << " differs between two runs with one seed";
  }
  EXPECT_FALSE(readBytes(a.path() / "session-01.lcmlog") ==
               readBytes(c.path() / "session-01.lcmlog"));
  // Nothing is left under a temporary name.
  for (const auto& e : fs::directory_iterator(a.path())) {
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  }
}

TEST(SimRun, SidecarIsAConfigurationThatRegeneratesTheRun) {
  TempDir a("sidecar-a"), b("sidecar-b");
  SimOptions o = testing::smallRun(23);
  o.sensors.vo.rate_hz = 15.0;
  write(o, a.path());
  auto file = KeyValueFile::load(a.path() / "run.sim.txt");
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_NE(file->find("meta.floor.2.height_m"), nullptr);
  ASSERT_NE(file->find("meta.session.1"), nullptr);
  auto again = loadSimOptions(*file);
  ASSERT_TRUE(again.ok()) << again.error().message;
  write(*again, b.path());
  EXPECT_TRUE(readBytes(a.path() / "session-01.lcmlog") ==
              readBytes(b.path() / "session-01.lcmlog"));
}

TEST(SimRun, LogsHoldTheGeneratedMessagesInTimeOrder) {
  TempDir a("read");
  const WrittenRun w = write(testing::smallRun(24), a.path());
  std::map<std::string, int64_t> counts;
  int64_t last = 0;
  int64_t gt = 0;
  std::ifstream tum(a.path() / "session-00.tum");
  std::string header;
  std::getline(tum, header);
  for (const fs::path& log : w.logs) {
    lcm::LogFile file(log.string(), "r");
    ASSERT_TRUE(file.good());
    while (const lcm::LogEvent* ev = file.readNextEvent()) {
      EXPECT_GE(ev->timestamp, last);
      last = ev->timestamp;
      ++counts[ev->channel];
      if (ev->channel == channels::kGroundTruth && log == w.logs[0]) {
        pose_t p;
        ASSERT_GT(p.decode(ev->data, 0, ev->datalen), 0);
        EXPECT_EQ(p.utime, ev->timestamp);
        double t, x, y, z, qx, qy, qz, qw;
        ASSERT_TRUE(tum >> t >> x >> y >> z >> qx >> qy >> qz >> qw);
        EXPECT_NEAR(t, p.utime * 1e-6, 1e-6);
        EXPECT_NEAR(x, p.position[0], 1e-8);
        EXPECT_NEAR(qw, p.orientation[0], 1e-8);
        ++gt;
      }
    }
  }
  for (const auto& [channel, c] : w.summary.channels)
    EXPECT_EQ(counts[channel], c.messages) << channel;
  EXPECT_GT(gt, 100);
}

TEST(SimRun, OneLogForTheWholeRunWhenSessionsAreNotSplit) {
  TempDir a("whole");
  SimOptions o = testing::smallRun(25);
  o.output.split_sessions = false;
  o.output.tum = false;
  const WrittenRun w = write(o, a.path());
  ASSERT_EQ(w.logs.size(), 1u);
  EXPECT_TRUE(fs::exists(a.path() / "run.lcmlog"));
  EXPECT_FALSE(fs::exists(a.path() / "run.tum"));
}

TEST(SimRun, UnwritableFolderIsAnErrorNamingIt) {
  TempDir a("blocked");
  fs::create_directories(a.path());
  std::ofstream(a.path() / "file") << "x";
  auto plan = RunPlan::create(testing::smallRun());
  ASSERT_TRUE(plan.ok());
  auto w = writeRun(*plan, a.path() / "file" / "out");
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().message.find((a.path() / "file" / "out").string()), std::string::npos)
      << w.error().message;
}

TEST(SimRun, ScheduleVisitsEveryFloorInSessionsThatDoNotOverlap) {
  SimOptions o = testing::smallRun(26);
  o.building.floors = 5;
  o.patrol.sessions = 3;
  auto plan = RunPlan::create(o);
  ASSERT_TRUE(plan.ok());
  std::set<int> floors;
  int64_t previous_end = 0;
  for (int i = 0; i < plan->sessions(); ++i) {
    const SessionPlan s = plan->session(i);
    floors.insert(s.floors_visited.begin(), s.floors_visited.end());
    EXPECT_GT(s.trajectory->startUtime(), previous_end);
    previous_end = s.trajectory->endUtime();
    // Sessions start and end at home, at rest.
    const BodyState first = s.trajectory->at(s.trajectory->startUtime());
    const BodyState last = s.trajectory->at(s.trajectory->endUtime());
    EXPECT_LT((first.world_T_body.translation() - last.world_T_body.translation()).norm(), 1e-9);
    EXPECT_EQ(last.floor, o.building.main_floor);
    EXPECT_LT(last.velocity_world.norm(), 1e-9);
  }
  EXPECT_EQ(floors.size(), 5u);
}

}  // namespace
}  // namespace evermap::sim
