#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/core/preprocess/keyframe_selector.h"

namespace ccir_mapping::core::preprocess {
namespace {

Pose3 at(double x, double yaw = 0.0) {
  Pose3 pose = Pose3::Identity();
  pose.translation().x() = x;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

using Outcome = KeyframeSelector::Outcome;

TEST(KeyframeSelector, FirstScanIsKeyframeZero) {
  KeyframeSelector selector({1.0, 0.5});
  const auto d = selector.offer(fromSeconds(1.0), at(0.0));
  EXPECT_EQ(d.outcome, Outcome::kKeyframe);
  EXPECT_EQ(d.id, 0u);
  EXPECT_EQ(d.travelled_m, 0.0);
}

TEST(KeyframeSelector, DistanceIsPathLengthSinceLastKeyframe) {
  KeyframeSelector selector({1.0, 10.0});
  selector.offer(fromSeconds(0.0), at(0.0));
  EXPECT_EQ(selector.offer(fromSeconds(0.1), at(0.4)).outcome, Outcome::kSkipped);
  // Back and forth: the straight-line distance stays 0.2 m, the path is 0.8 m.
  EXPECT_EQ(selector.offer(fromSeconds(0.2), at(0.2)).outcome, Outcome::kSkipped);
  const auto d = selector.offer(fromSeconds(0.3), at(0.4));
  EXPECT_EQ(d.outcome, Outcome::kSkipped);
  EXPECT_NEAR(d.travelled_m, 0.8, 1e-12);
  const auto k = selector.offer(fromSeconds(0.4), at(0.6));
  EXPECT_EQ(k.outcome, Outcome::kKeyframe);
  EXPECT_EQ(k.id, 1u);
  EXPECT_NEAR(k.travelled_m, 1.0, 1e-12);
  // The count restarts at the new keyframe.
  EXPECT_NEAR(selector.offer(fromSeconds(0.5), at(0.9)).travelled_m, 0.3, 1e-12);
}

TEST(KeyframeSelector, RotationAloneMakesAKeyframe) {
  KeyframeSelector selector({100.0, 0.5});
  selector.offer(fromSeconds(0.0), at(0.0, 0.0));
  EXPECT_EQ(selector.offer(fromSeconds(0.1), at(0.0, 0.3)).outcome, Outcome::kSkipped);
  const auto d = selector.offer(fromSeconds(0.2), at(0.0, -0.6));  // 0.6 rad from the keyframe
  EXPECT_EQ(d.outcome, Outcome::kKeyframe);
  EXPECT_NEAR(d.rotated_rad, 0.6, 1e-9);
}

TEST(KeyframeSelector, StampsGoingBackwardsChangeNothing) {
  KeyframeSelector selector({1.0, 1.0});
  selector.offer(fromSeconds(2.0), at(0.0));
  EXPECT_EQ(selector.offer(fromSeconds(1.0), at(5.0)).outcome, Outcome::kStampNotIncreasing);
  EXPECT_EQ(selector.offer(fromSeconds(2.0), at(5.0)).outcome, Outcome::kStampNotIncreasing);
  // The rejected poses did not count as travel.
  EXPECT_NEAR(selector.offer(fromSeconds(3.0), at(0.5)).travelled_m, 0.5, 1e-12);
  EXPECT_EQ(selector.nextId(), 1u);
}

TEST(KeyframeSelector, NonFinitePoseIsRejected) {
  KeyframeSelector selector({1.0, 1.0});
  Pose3 bad = at(0.0);
  bad.translation().y() = std::nan("");
  EXPECT_EQ(selector.offer(fromSeconds(1.0), bad).outcome, Outcome::kInvalidPose);
  EXPECT_EQ(selector.offer(fromSeconds(1.0), at(0.0)).outcome, Outcome::kKeyframe);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
