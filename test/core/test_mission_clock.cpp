#include <gtest/gtest.h>

#include "ccir_mapping/core/common/mission_clock.h"

namespace ccir_mapping::core {
namespace {

TEST(MissionClock, FollowsMissionTimeWhileItAdvances) {
  MissionClock clock(0.5);
  EXPECT_DOUBLE_EQ(clock.now(100.0, 0.0), 0.0);
  // Replayed at half speed: mission seconds count, not wall seconds.
  for (int i = 1; i <= 20; ++i) EXPECT_NEAR(clock.now(100.0 + 0.05 * i, 0.1 * i), 0.05 * i, 1e-9);
}

TEST(MissionClock, FollowsTheWallClockWhileMissionTimeStandsStill) {
  MissionClock clock(0.5);
  clock.now(10.0, 0.0);
  clock.now(11.0, 1.0);
  EXPECT_DOUBLE_EQ(clock.now(11.0, 1.4), 1.0) << "within the stall time";
  EXPECT_DOUBLE_EQ(clock.now(11.0, 2.0), 1.5) << "the replay ended at 1.0 s: 0.5 s stalled";
  EXPECT_DOUBLE_EQ(clock.now(11.0, 4.0), 3.5);
  // The replay resumes: mission time again, from where the clock stood.
  EXPECT_DOUBLE_EQ(clock.now(11.5, 4.1), 4.0);
}

TEST(MissionClock, NeverGoesBack) {
  MissionClock clock(0.5);
  clock.now(50.0, 0.0);
  clock.now(51.0, 1.0);
  EXPECT_DOUBLE_EQ(clock.now(20.0, 1.1), 1.0) << "a bag replayed again";
  EXPECT_DOUBLE_EQ(clock.now(20.5, 1.2), 1.5) << "followed from where it is";
}

}  // namespace
}  // namespace ccir_mapping::core
