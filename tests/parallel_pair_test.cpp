#include "core/common/parallel_pair.h"

#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace evermap::core {
namespace {

TEST(ParallelPair, RunsBothTasksOnTwoThreadsAndReturnsWhenBothAreDone) {
  ParallelPair pair(2);
  EXPECT_EQ(pair.threads(), 2);
  for (int step = 0; step < 100; ++step) {
    std::vector<int> out(2, 0);
    std::thread::id first_id, second_id;
    pair.run(
        [&] {
          first_id = std::this_thread::get_id();
          out[0] = step;
        },
        [&] {
          second_id = std::this_thread::get_id();
          out[1] = step + 1;
        });
    EXPECT_EQ(out[0], step);
    EXPECT_EQ(out[1], step + 1);
    EXPECT_EQ(first_id, std::this_thread::get_id());
    EXPECT_NE(second_id, std::this_thread::get_id());
  }
}

TEST(ParallelPair, WithOneThreadRunsFirstThenSecondOnTheCaller) {
  ParallelPair pair(1);
  EXPECT_EQ(pair.threads(), 1);
  std::vector<int> order;
  pair.run([&] { order.push_back(1); }, [&] { order.push_back(2); });
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
}

TEST(ParallelPair, RethrowsTheWorkersExceptionAfterBothAreDoneAndKeepsWorking) {
  ParallelPair pair(2);
  bool first_done = false;
  EXPECT_THROW(pair.run([&] { first_done = true; }, [] { throw std::runtime_error("worker"); }),
               std::runtime_error);
  EXPECT_TRUE(first_done);
  int x = 0;
  pair.run([] {}, [&] { x = 5; });
  EXPECT_EQ(x, 5);
}

TEST(ParallelPair, WithoutAPairRunBothCallsBothInOrder) {
  std::vector<int> order;
  runBoth(
      nullptr, [&] { order.push_back(1); }, [&] { order.push_back(2); });
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
}

}  // namespace
}  // namespace evermap::core
