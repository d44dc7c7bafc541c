// The Preprocessor's per-scan decisions (core::preprocess::KeyframeStage): arrival order and
// missing scans, too few usable points, keyframe selection, gravity from the sensor's pose, and
// parameters that change between scans.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/preprocess/keyframe_stage.h"

namespace ccir_mapping::core::preprocess {
namespace {

using Input = KeyframeStage::InputCloud;
using Outcome = KeyframeStage::Outcome;

constexpr Stamp kPeriod = 100'000'000;  // 10 Hz

/// A box room around the sensor (floor z = -1, ceiling z = 2, walls x = +-4, y = +-3) every 0.1 m.
Input room() {
  Input cloud;
  const auto add = [&](float x, float y, float z) {
    pcl::PointXYZI p;
    p.x = x;
    p.y = y;
    p.z = z;
    p.intensity = 1.0F;
    cloud.push_back(p);
  };
  for (float a = -4; a <= 4.01F; a += 0.1F) {
    for (float b = -3; b <= 3.01F; b += 0.1F) {
      add(a, b, -1);
      add(a, b, 2);
    }
    for (float z = -1; z <= 2.01F; z += 0.1F) {
      add(a, 3, z);
      add(a, -3, z);
    }
  }
  for (float b = -3; b <= 3.01F; b += 0.1F) {
    for (float z = -1; z <= 2.01F; z += 0.1F) {
      add(4, b, z);
      add(-4, b, z);
    }
  }
  return cloud;
}

Pose3 at(double x) {
  Pose3 pose = Pose3::Identity();
  pose.translation().x() = x;
  return pose;
}

TEST(KeyframeStage, ArrivalsMustAdvanceAndGapsAreCounted) {
  KeyframeStage stage{PreprocessorParams{}};
  std::uint64_t missing = 7;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(stage.arrive(i * kPeriod, &missing));
    EXPECT_EQ(missing, 0U);
  }
  EXPECT_FALSE(stage.arrive(4 * kPeriod, &missing)) << "a repeated stamp";
  EXPECT_FALSE(stage.arrive(2 * kPeriod, &missing)) << "a stamp going back";
  ASSERT_TRUE(stage.arrive(8 * kPeriod, &missing));  // 5, 6 and 7 lost
  EXPECT_EQ(missing, 3U);
  EXPECT_EQ(stage.totals().missed_scans, 3U);
}

TEST(KeyframeStage, MakesKeyframesFromTravelAndNeverFromTooFewPoints) {
  PreprocessorParams params;
  params.min_points = 50;
  KeyframeStage stage{params};
  const Input scan = room();
  Input sparse;
  sparse.insert(sparse.end(), scan.begin(), scan.begin() + 40);

  auto result = stage.process(0, at(0.0), sparse);
  EXPECT_EQ(result.outcome, Outcome::kTooFewPoints);
  EXPECT_EQ(result.usable_points, 40U);

  result = stage.process(kPeriod, at(0.0), scan);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  EXPECT_EQ(result.decision.id, 0U) << "a refused scan takes no id";
  ASSERT_TRUE(result.cloud);
  EXPECT_GT(result.cloud->size(), 1000U);
  EXPECT_EQ(result.stats.points_out, result.cloud->size());

  EXPECT_EQ(stage.process(2 * kPeriod, at(0.5), scan).outcome, Outcome::kSkipped);
  EXPECT_EQ(stage.process(2 * kPeriod, at(1.5), scan).outcome, Outcome::kStampNotIncreasing);
  Pose3 broken = at(1.5);
  broken.translation().y() = std::nan("");
  EXPECT_EQ(stage.process(3 * kPeriod, broken, scan).outcome, Outcome::kInvalidPose);
  result = stage.process(4 * kPeriod, at(1.1), scan);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  EXPECT_EQ(result.decision.id, 1U);
  EXPECT_NEAR(result.decision.travelled_m, 1.1, 1e-9);
  EXPECT_EQ(stage.totals().keyframes, 2U);
  EXPECT_EQ(stage.totals().last_points_out, result.cloud->size());
}

TEST(KeyframeStage, TakesGravityFromTheSensorPose) {
  // The room as a sensor rolled 90 degrees about x sees it: what it calls y is up, so the
  // "horizontal" points it drops are those of its y = +-3 planes, not of its z planes.
  PreprocessorParams params;
  params.drop_horizontal = HorizontalFilter::kBoth;
  const Input scan = room();
  Pose3 rolled = Pose3::Identity();
  rolled.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (const bool roll : {false, true}) {
    KeyframeStage stage{params};
    const auto result = stage.process(0, roll ? rolled : Pose3::Identity(), scan);
    ASSERT_EQ(result.outcome, Outcome::kKeyframe);
    std::size_t on_z_planes = 0, on_y_planes = 0;
    for (const auto& p : *result.cloud) {
      on_z_planes += std::abs(p.normal_z) > 0.9F;
      on_y_planes += std::abs(p.normal_y) > 0.9F;
    }
    EXPECT_GT(roll ? on_z_planes : on_y_planes, 500U) << "roll " << roll;
    EXPECT_EQ(roll ? on_y_planes : on_z_planes, 0U) << "roll " << roll;
  }
}

TEST(KeyframeStage, NewParametersTakeEffectFromTheNextScan) {
  KeyframeStage stage{PreprocessorParams{}};
  const Input scan = room();
  ASSERT_EQ(stage.process(0, at(0.0), scan).outcome, Outcome::kKeyframe);
  EXPECT_EQ(stage.process(kPeriod, at(0.6), scan).outcome, Outcome::kSkipped);
  PreprocessorParams closer;
  closer.keyframe_distance_m = 0.5;
  closer.min_points = 100000;
  stage.setParams(closer);
  EXPECT_EQ(stage.params().keyframe_distance_m, 0.5);
  EXPECT_EQ(stage.process(2 * kPeriod, at(0.7), scan).outcome, Outcome::kTooFewPoints);
  closer.min_points = 10;
  stage.setParams(closer);
  EXPECT_EQ(stage.process(3 * kPeriod, at(0.7), scan).outcome, Outcome::kKeyframe);
  closer.voxel_leaf_m = -1.0;
  EXPECT_THROW(stage.setParams(closer), std::invalid_argument);
  EXPECT_THROW(KeyframeStage{closer}, std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
