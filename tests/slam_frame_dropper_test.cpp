#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "tools/slam-run/frame_dropper.h"

namespace evermap::slam_run {
namespace {

// Lengths of the runs of dropped frames over `frames` frames.
std::vector<int> dropRuns(FrameDropper& d, int frames) {
  std::vector<int> runs;
  int run = 0;
  for (int i = 0; i < frames; ++i) {
    if (d.drop(i)) {
      ++run;
    } else if (run > 0) {
      runs.push_back(run);
      run = 0;
    }
  }
  return runs;
}

TEST(FrameDropper, DropsNothingByDefault) {
  FrameDropper d;
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(d.drop(i));
  EXPECT_EQ(d.dropped(), 0);
  EXPECT_EQ(d.frames(), 1000);
}

TEST(FrameDropper, DropsTheFractionAskedForOverALongRun) {
  for (double f : {0.05, 0.10, 0.3}) {
    FrameDropOptions o;
    o.fraction = f;
    FrameDropper d(o);
    dropRuns(d, 400000);  // about 10^4 drops: the count is within a few per cent
    EXPECT_NEAR(static_cast<double>(d.dropped()) / static_cast<double>(d.frames()), f, 0.05 * f)
        << "fraction " << f;
  }
}

TEST(FrameDropper, DropsSingleFramesAndBurstsOfTheGivenLength) {
  FrameDropOptions o;
  o.fraction = 0.1;
  o.burst_probability = 0.3;
  o.burst_frames = 5;
  FrameDropper d(o);
  const std::vector<int> runs = dropRuns(d, 100000);
  int singles = 0, bursts = 0;
  for (int r : runs) {
    // A burst can follow a single drop at once (a run of 6) or two drops can touch: runs are
    // sums of 1s and 5s.
    if (r == 1) ++singles;
    if (r == 5) ++bursts;
  }
  ASSERT_GT(singles + bursts, 1000);
  EXPECT_NEAR(static_cast<double>(bursts) / (singles + bursts), 0.3, 0.05);
}

TEST(FrameDropper, TheSameSeedDropsTheSameFrames) {
  FrameDropOptions o;
  o.fraction = 0.05;
  o.seed = 7;
  FrameDropper a(o), b(o);
  for (int i = 0; i < 5000; ++i) ASSERT_EQ(a.drop(i), b.drop(i)) << "frame " << i;
  o.seed = 8;
  FrameDropper c(o);
  FrameDropper a2(FrameDropOptions{0.05, 0.3, 5, 7, {}});
  int differ = 0;
  for (int i = 0; i < 5000; ++i) differ += a2.drop(i) != c.drop(i);
  EXPECT_GT(differ, 0);
}

TEST(FrameDropper, RefusesAFractionOutsideItsRange) {
  EXPECT_FALSE((FrameDropOptions{0.6, 0.3, 5, 1, {}}).validate().ok());
  EXPECT_FALSE((FrameDropOptions{-0.1, 0.3, 5, 1, {}}).validate().ok());
  EXPECT_FALSE((FrameDropOptions{0.1, 1.5, 5, 1, {}}).validate().ok());
  EXPECT_FALSE((FrameDropOptions{0.1, 0.3, 0, 1, {}}).validate().ok());
  EXPECT_TRUE((FrameDropOptions{0.1, 0.3, 5, 1, {}}).validate().ok());
}

TEST(FrameDropper, DropsTheFramesALiveVoProcDroppedAsItsLogNamesThem) {
  const auto file = std::filesystem::temp_directory_path() / "evermap_dropped_frames.log";
  std::ofstream(file) << "[deputy 2026-11-30T19:45:54.380] started pid 2061\n"
                         "evermap-vo-proc: message clock starts at 1000 (3 messages agree)\n"
                         "evermap-vo-proc: dropped behind the queue: frame 1100\n"
                         "evermap-vo-proc: dropped behind the queue: frame 1150\n"
                         "1300\n"
                         "evermap-vo-proc: 4800 frames: ok 4799; 2 frames dropped behind\n";
  const auto utimes = readDroppedFrames(file);
  std::filesystem::remove(file);
  ASSERT_TRUE(utimes.ok()) << utimes.error().message;
  EXPECT_EQ(*utimes, (std::vector<int64_t>{1100, 1150, 1300}));
  FrameDropOptions o;
  o.utimes = *utimes;
  FrameDropper d(o);
  std::vector<int64_t> dropped;
  for (int64_t t = 1000; t <= 1400; t += 50) {
    if (d.drop(t)) dropped.push_back(t);
  }
  EXPECT_EQ(dropped, (std::vector<int64_t>{1100, 1150, 1300}));
  EXPECT_EQ(d.dropped(), 3);
  EXPECT_EQ(d.namedDropped(), 3);
}

TEST(FrameDropper, AVoProcLogThatDroppedNothingNamesNoFrameAndTheLogOfTwoRunsIsRefused) {
  const auto file = std::filesystem::temp_directory_path() / "evermap_dropped_none.log";
  std::ofstream(file) << "evermap-vo-proc: 4800 frames: ok 4800; 0 frames dropped behind "
                         "(queue 2)\n";
  const auto none = readDroppedFrames(file);
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_TRUE(none->empty());
  std::ofstream(file) << "evermap-vo-proc: dropped behind the queue: frame 1200\n"
                         "evermap-vo-proc: 10 frames: ok 9; 1 frames dropped behind (queue 2)\n"
                         "evermap-vo-proc: dropped behind the queue: frame 1100\n";
  const auto two_runs = readDroppedFrames(file);
  std::filesystem::remove(file);
  ASSERT_FALSE(two_runs.ok());
  EXPECT_NE(two_runs.error().message.find(file.string() + ":3: frame 1100 is before the one "
                                                          "above (1200)"),
            std::string::npos)
      << two_runs.error().message;
}

TEST(FrameDropper, AFileWithoutFrameTimesIsAnErrorNamingIt) {
  const auto file = std::filesystem::temp_directory_path() / "evermap_no_dropped_frames.log";
  std::ofstream(file) << "evermap-mapper-proc: steps 4800\nnodes 107\n";  // not vo-proc's
  const auto utimes = readDroppedFrames(file);
  std::filesystem::remove(file);
  ASSERT_FALSE(utimes.ok());
  EXPECT_NE(utimes.error().message.find(file.string() + ": no frame time"), std::string::npos)
      << utimes.error().message;
  EXPECT_FALSE(readDroppedFrames(file).ok());  // and one that is not there
}

}  // namespace
}  // namespace evermap::slam_run
