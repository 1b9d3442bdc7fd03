// StopSignals: SIGINT/SIGTERM are blocked and seen by polling, and stay seen.
#include <gtest/gtest.h>

#include <csignal>

#include "core/common/stop_signals.h"

namespace evermap {
namespace {

TEST(StopSignals, ASignalSentToTheProcessIsSeenByPollingAndStaysSeen) {
  StopSignals stop;
  EXPECT_FALSE(stop.requested());
  // Blocked: the default action (ending the test program) does not happen; it waits.
  ASSERT_EQ(std::raise(SIGTERM), 0);
  EXPECT_TRUE(stop.requested());
  EXPECT_TRUE(stop.requested());
  StopSignals second;
  EXPECT_FALSE(second.requested());  // the signal was taken by the first
  ASSERT_EQ(std::raise(SIGINT), 0);
  EXPECT_TRUE(second.requested());
}

}  // namespace
}  // namespace evermap
