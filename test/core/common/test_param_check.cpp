#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core {
namespace {

TEST(ParamCheck, RangeErrorsNameTheParameterAndTheRange) {
  ParamCheck check;
  check.inRange("voxel_leaf_m", -1.0, 0.01, 5.0);
  check.inHalfOpenRange("max_range_m", 0.0, 0.0, 300.0);
  ASSERT_EQ(check.errors().size(), 2u);
  EXPECT_EQ(check.errors()[0], "voxel_leaf_m = -1 is out of range: allowed [0.01, 5]");
  EXPECT_EQ(check.errors()[1], "max_range_m = 0 is out of range: allowed (0, 300]");
}

TEST(ParamCheck, BoundsAreInclusiveWhereDocumented) {
  ParamCheck check;
  check.inRange("a", 0.01, 0.01, 5.0);
  check.inRange("b", 5.0, 0.01, 5.0);
  check.inHalfOpenRange("c", 300.0, 0.0, 300.0);
  EXPECT_TRUE(check.ok());
}

TEST(ParamCheck, NanIsNeverInRange) {
  ParamCheck check;
  check.inRange("x", std::nan(""), -1e300, 1e300);
  EXPECT_FALSE(check.ok());
}

TEST(ParamCheck, RobotNames) {
  EXPECT_TRUE(isValidRobotName("robot_a"));
  EXPECT_TRUE(isValidRobotName("uav3"));
  EXPECT_FALSE(isValidRobotName(""));
  EXPECT_FALSE(isValidRobotName("3uav"));
  EXPECT_FALSE(isValidRobotName("robot/a"));
  EXPECT_FALSE(isValidRobotName("robot a"));
}

}  // namespace
}  // namespace ccir_mapping::core
