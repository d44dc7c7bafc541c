#include <gtest/gtest.h>

#include "ccir_mapping/core/common/mission_clock.h"
#include "ccir_mapping/core/common/periodic_schedule.h"

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

TEST(PeriodicSchedule, OncePerPeriodAndOnceAfterAJump) {
  PeriodicSchedule every_second(1.0);
  EXPECT_FALSE(every_second.due(0.0));
  EXPECT_FALSE(every_second.due(0.99));
  EXPECT_TRUE(every_second.due(1.02));
  EXPECT_FALSE(every_second.due(1.5));
  EXPECT_TRUE(every_second.due(2.0)) << "due times do not drift with late looks";
  EXPECT_TRUE(every_second.due(50.0)) << "a jump";
  EXPECT_FALSE(every_second.due(50.5));
  EXPECT_TRUE(every_second.due(51.0));
}

}  // namespace
}  // namespace ccir_mapping::core
