#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/core/preprocess/odometry_buffer.h"

namespace ccir_mapping::core::preprocess {
namespace {

Pose3 pose(double x, double yaw) {
  Pose3 p = Pose3::Identity();
  p.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

double yawOf(const Pose3& p) { return std::atan2(p.linear()(1, 0), p.linear()(0, 0)); }

TEST(OdometryBuffer, InterpolatesBetweenSamples) {
  OdometryBuffer buffer;
  ASSERT_TRUE(buffer.add(fromSeconds(1.0), pose(0.0, 0.0)));
  ASSERT_TRUE(buffer.add(fromSeconds(1.1), pose(1.0, 0.2)));
  const auto p = buffer.at(fromSeconds(1.025), 0.1);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->translation().x(), 0.25, 1e-9);
  EXPECT_NEAR(yawOf(*p), 0.05, 1e-9);
  EXPECT_TRUE(isValidPose(*p));
}

TEST(OdometryBuffer, ExactStampReturnsTheSample) {
  OdometryBuffer buffer;
  buffer.add(fromSeconds(1.0), pose(3.0, 0.1));
  buffer.add(fromSeconds(2.0), pose(4.0, 0.1));
  EXPECT_NEAR(buffer.at(fromSeconds(2.0), 0.0)->translation().x(), 4.0, 1e-12);
}

TEST(OdometryBuffer, NearestSampleOnlyWithinTolerance) {
  OdometryBuffer buffer;
  buffer.add(fromSeconds(1.0), pose(0.0, 0.0));
  EXPECT_TRUE(buffer.at(fromSeconds(1.05), 0.1).has_value());
  EXPECT_FALSE(buffer.at(fromSeconds(1.2), 0.1).has_value());
  EXPECT_FALSE(buffer.at(fromSeconds(0.8), 0.1).has_value());
}

TEST(OdometryBuffer, DoesNotInterpolateAcrossLongGaps) {
  OdometryBuffer buffer;
  buffer.add(fromSeconds(1.0), pose(0.0, 0.0));
  buffer.add(fromSeconds(3.0), pose(10.0, 0.0));
  EXPECT_FALSE(buffer.at(fromSeconds(2.0), 0.1).has_value());
  EXPECT_NEAR(buffer.at(fromSeconds(2.95), 0.1)->translation().x(), 10.0, 1e-12);
}

TEST(OdometryBuffer, RejectsOutOfOrderAndNonFiniteSamples) {
  OdometryBuffer buffer;
  EXPECT_TRUE(buffer.add(fromSeconds(2.0), pose(0.0, 0.0)));
  EXPECT_FALSE(buffer.add(fromSeconds(1.0), pose(1.0, 0.0)));
  EXPECT_FALSE(buffer.add(fromSeconds(2.0), pose(1.0, 0.0)));
  EXPECT_FALSE(buffer.add(fromSeconds(3.0), pose(std::nan(""), 0.0)));
  EXPECT_EQ(*buffer.newestStamp(), fromSeconds(2.0));
}

TEST(OdometryBuffer, ForgetsSamplesOlderThanTheHorizon) {
  OdometryBuffer buffer(1.0);
  buffer.add(fromSeconds(0.0), pose(0.0, 0.0));
  buffer.add(fromSeconds(5.0), pose(5.0, 0.0));
  EXPECT_FALSE(buffer.at(fromSeconds(0.0), 0.01).has_value());
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
