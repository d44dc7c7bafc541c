// The Preprocessor's per-scan decisions (core::preprocess::PreprocessorStage): arrival order and
// missing scans, too few usable points, keyframe selection, gravity from the sensor's pose, and
// parameters that change between scans.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/preprocess/preprocessor_stage.h"

namespace ccir_mapping::core::preprocess {
namespace {

using Input = PreprocessorStage::InputCloud;
using Outcome = PreprocessorStage::Outcome;

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

TEST(PreprocessorStage, ArrivalsMustAdvanceAndGapsAreCounted) {
  PreprocessorStage stage{PreprocessorParams{}};
  for (int i = 0; i < 5; ++i) {
    const auto arrival = stage.arrive(i * kPeriod, 1000);
    ASSERT_TRUE(arrival.accepted);
    EXPECT_EQ(arrival.missing_before, 0U);
    EXPECT_TRUE(arrival.notices.empty());
  }
  const auto repeated = stage.arrive(4 * kPeriod, 1000);
  EXPECT_FALSE(repeated.accepted) << "a repeated stamp";
  ASSERT_EQ(repeated.notices.size(), 1U);
  EXPECT_EQ(repeated.notices[0].text,
            "stamp not after the previous scan (a bag replayed again? restart the pipeline)");
  EXPECT_FALSE(stage.arrive(2 * kPeriod, 1000).accepted) << "a stamp going back";
  const auto after_gap = stage.arrive(8 * kPeriod, 1000);  // 5, 6 and 7 lost
  ASSERT_TRUE(after_gap.accepted);
  EXPECT_EQ(after_gap.missing_before, 3U);
  ASSERT_EQ(after_gap.notices.size(), 1U);
  EXPECT_EQ(after_gap.notices[0].kind, "missing scans");
  EXPECT_EQ(after_gap.notices[0].text.rfind("3 scan(s) missing before 0.800 (3 so far): ", 0), 0U)
      << after_gap.notices[0].text;
  EXPECT_EQ(stage.totals().missed_scans, 3U);
}

TEST(PreprocessorStage, ACloudOfMoreThanMaxPointsIsRefusedAndItsStampStillCounts) {
  PreprocessorParams params;
  params.max_points = 5000;
  PreprocessorStage stage{params};
  ASSERT_TRUE(stage.arrive(0, 5000).accepted);
  const auto huge = stage.arrive(kPeriod, 10000000);
  EXPECT_FALSE(huge.accepted);
  ASSERT_FALSE(huge.notices.empty());
  EXPECT_EQ(huge.notices[0].kind, "too many points");
  EXPECT_EQ(huge.notices[0].text.rfind("10000000 points, more than max_points 5000", 0), 0U)
      << huge.notices[0].text;
  const auto next = stage.arrive(2 * kPeriod, 3000);
  EXPECT_TRUE(next.accepted);
  EXPECT_EQ(next.missing_before, 0U) << "the refused scan arrived: no gap";
  params.min_points = 6000;
  EXPECT_FALSE(params.validate().empty()) << "max_points below min_points";
}

TEST(PreprocessorStage, MakesKeyframesFromTravelAndNeverFromTooFewPoints) {
  PreprocessorParams params;
  params.min_points = 50;
  PreprocessorStage stage{params};
  const Input scan = room();
  Input sparse;
  sparse.insert(sparse.end(), scan.begin(), scan.begin() + 40);

  auto result = stage.process(0, at(0.0), sparse);
  EXPECT_EQ(result.outcome, Outcome::kTooFewPoints);
  EXPECT_TRUE(result.dropped());
  EXPECT_EQ(result.usable_points, 40U);
  ASSERT_EQ(result.notices.size(), 1U);
  EXPECT_EQ(result.notices[0].text,
            "only 40 of 40 points are finite and within [0.5, 100] m (min_points 50)");

  result = stage.process(kPeriod, at(0.0), scan);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  EXPECT_EQ(result.decision.id, 0U) << "a refused scan takes no id";
  ASSERT_TRUE(result.cloud);
  EXPECT_GT(result.cloud->size(), 1000U);
  EXPECT_EQ(result.stats.points_out, result.cloud->size());

  EXPECT_TRUE(result.notices.empty());
  result = stage.process(2 * kPeriod, at(0.5), scan);
  EXPECT_EQ(result.outcome, Outcome::kSkipped);
  EXPECT_FALSE(result.dropped());
  EXPECT_TRUE(result.notices.empty());
  result = stage.process(2 * kPeriod, at(1.5), scan);
  EXPECT_EQ(result.outcome, Outcome::kStampNotIncreasing);
  ASSERT_EQ(result.notices.size(), 1U);
  EXPECT_EQ(result.notices[0].kind, "stamp not increasing");
  Pose3 broken = at(1.5);
  broken.translation().y() = std::nan("");
  result = stage.process(3 * kPeriod, broken, scan);
  EXPECT_EQ(result.outcome, Outcome::kInvalidPose);
  ASSERT_EQ(result.notices.size(), 1U);
  EXPECT_EQ(result.notices[0].text, "its pose is not finite");
  result = stage.process(4 * kPeriod, at(1.1), scan);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  EXPECT_EQ(result.decision.id, 1U);
  EXPECT_NEAR(result.decision.travelled_m, 1.1, 1e-9);
  EXPECT_EQ(stage.totals().keyframes, 2U);
  EXPECT_EQ(stage.totals().last_points_out, result.cloud->size());
}

TEST(PreprocessorStage, ReportsWhatIsOddAboutAScanItUses) {
  // Non-finite points belong in organised clouds only (a missing return keeps its place).
  Input scan = room();
  for (int i = 0; i < 10; ++i) scan[i].x = std::nanf("");
  PreprocessorStage stage{PreprocessorParams{}};
  auto result = stage.process(0, at(0.0), scan);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  ASSERT_EQ(result.notices.size(), 1U);
  EXPECT_EQ(result.notices[0].kind, "not finite");
  EXPECT_EQ(result.notices[0].text.rfind("10 of " + std::to_string(scan.size()) +
                                             " points are NaN, infinite or zero in an "
                                             "unorganised cloud",
                                         0),
            0U);
  scan.resize(scan.size() / 2 * 2);
  scan.width = static_cast<std::uint32_t>(scan.size() / 2);
  scan.height = 2;
  EXPECT_TRUE(stage.process(kPeriod, at(2.0), scan).notices.empty()) << "organised";

  // A keyframe the filters leave empty: a floor, and horizontal points dropped.
  PreprocessorParams params;
  params.drop_horizontal = HorizontalFilter::kBoth;
  PreprocessorStage floor_only{params};
  Input floor;
  for (const auto& p : room()) {
    if (p.z < -0.99F) floor.push_back(p);
  }
  result = floor_only.process(0, at(0.0), floor);
  ASSERT_EQ(result.outcome, Outcome::kKeyframe);
  ASSERT_TRUE(result.cloud);
  EXPECT_TRUE(result.cloud->empty());
  ASSERT_EQ(result.notices.size(), 1U);
  EXPECT_EQ(result.notices[0].kind, "empty keyframe");
  EXPECT_EQ(result.notices[0].text.rfind("keyframe 0 has no point left after preprocessing (", 0),
            0U)
      << result.notices[0].text;
}

TEST(PreprocessorStage, TakesGravityFromTheSensorPose) {
  // The room as a sensor rolled 90 degrees about x sees it: what it calls y is up, so the
  // "horizontal" points it drops are those of its y = +-3 planes, not of its z planes.
  PreprocessorParams params;
  params.drop_horizontal = HorizontalFilter::kBoth;
  const Input scan = room();
  Pose3 rolled = Pose3::Identity();
  rolled.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (const bool roll : {false, true}) {
    PreprocessorStage stage{params};
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

TEST(PreprocessorStage, NewParametersTakeEffectFromTheNextScan) {
  PreprocessorStage stage{PreprocessorParams{}};
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
  EXPECT_THROW(PreprocessorStage{closer}, std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
