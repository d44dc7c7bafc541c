#include <gtest/gtest.h>

#include <limits>

#include "ccir_mapping/core/common/rate_meter.h"
#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core {
namespace {

TEST(Types, SecondsRoundToTheNearestNanosecond) {
  EXPECT_EQ(fromSeconds(1.025), 1025000000);
  EXPECT_EQ(fromSeconds(-0.1), -100000000);
  EXPECT_DOUBLE_EQ(toSeconds(fromSeconds(1234.5)), 1234.5);
}

TEST(Types, ValidPoses) {
  Pose3 pose = Pose3::Identity();
  EXPECT_TRUE(isValidPose(pose));
  pose.linear()(0, 0) = 2.0;  // not a rotation
  EXPECT_FALSE(isValidPose(pose));
  pose = Pose3::Identity();
  pose.translation().z() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(isValidPose(pose));
}

TEST(RateMeter, GrowthPerSecondSinceThePreviousReadingOfEachKey) {
  RateMeter meter;
  EXPECT_EQ(meter.rate("a", 10.0, 1000), 0.0) << "the first reading";
  EXPECT_EQ(meter.rate("b", 10.0, 50), 0.0);
  EXPECT_DOUBLE_EQ(meter.rate("a", 12.0, 1500), 250.0);
  EXPECT_EQ(meter.rate("a", 12.0, 1600), 0.0) << "the clock did not advance";
  EXPECT_DOUBLE_EQ(meter.rate("a", 13.0, 1700), 100.0);
  EXPECT_DOUBLE_EQ(meter.rate("b", 11.0, 50), 0.0);
}

}  // namespace
}  // namespace ccir_mapping::core
