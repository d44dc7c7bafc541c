// Team missions: parameter validation, robots starting at their own origin, time order and
// rates of what they record, determinism, overlap control, ground and aerial motion.
#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::simulation {
namespace {

/// Keeps everything a robot records.
class Recorder : public RecordingSink {
 public:
  void odometry(const OdometrySample& sample) override {
    odometry_.push_back(sample);
    emitted_.push_back(sample.stamp);
  }
  void scan(const LidarScan& scan, Stamp published) override {
    scans_.push_back(scan);
    emitted_.push_back(published);
  }
  std::vector<OdometrySample> odometry_;
  std::vector<LidarScan> scans_;
  std::vector<Stamp> emitted_;
};

MissionParams shortMission() {
  MissionParams params;
  params.robots = 2;
  params.duration_s = 2.0;
  params.start_interval_s = 0.5;
  params.lidar.lidar_columns = 360;  // keep the test quick; geometry is tested elsewhere
  return params;
}

TEST(MissionParams, DefaultsAreValidAndErrorsNameTheParameter) {
  EXPECT_TRUE(MissionParams().validate().empty());
  MissionParams none;
  none.robots = 0;
  ASSERT_FALSE(none.validate().empty());
  EXPECT_EQ(none.validate().front(), "robots = 0 is out of range: allowed [1, 200]");

  MissionParams too_many_aerial;
  too_many_aerial.aerial_robots = 4;
  ASSERT_EQ(too_many_aerial.validate().size(), 1U);
  EXPECT_EQ(too_many_aerial.validate().front().rfind("aerial_robots", 0), 0U);

  MissionParams too_high;
  too_high.aerial_robots = 1;
  too_high.aerial_max_height_m = 4.0;
  ASSERT_EQ(too_high.validate().size(), 1U);
  EXPECT_EQ(too_high.validate().front().rfind("aerial_max_height_m", 0), 0U);

  MissionParams bad_lidar;
  bad_lidar.lidar.lidar_range_noise_m = -1.0;
  bad_lidar.world.mine_pillars_x = 0;
  EXPECT_EQ(bad_lidar.validate().size(), 2U);  // nested structs' ranges are checked too
  EXPECT_THROW(Mission{bad_lidar}, std::invalid_argument);

  // Every world works with the default team, including an aerial robot.
  for (const auto& kind : WorldParams::worldChoices()) {
    MissionParams params;
    params.world.world = kind;
    params.aerial_robots = 1;
    EXPECT_TRUE(params.validate().empty()) << kind << ": " << params.validate().front();
  }
}

TEST(Mission, RobotNames) {
  EXPECT_EQ(Mission::robotName(0), "robot_a");
  EXPECT_EQ(Mission::robotName(25), "robot_z");
  EXPECT_EQ(Mission::robotName(26), "robot_ba");
}

TEST(Mission, EachRobotStartsAtTheOriginOfItsOwnFrame) {
  const Mission mission(shortMission());
  ASSERT_EQ(mission.robots().size(), 2U);
  const auto& a = mission.robots()[0];
  const auto& b = mission.robots()[1];
  EXPECT_NE(a.world_from_odom.translation(), b.world_from_odom.translation());
  EXPECT_DOUBLE_EQ(b.start_offset_s, 0.5);
  for (int i = 0; i < 2; ++i) {
    Recorder recorder;
    mission.record(i, recorder);
    ASSERT_FALSE(recorder.odometry_.empty());
    const auto& first = recorder.odometry_.front();
    EXPECT_EQ(first.stamp, mission.startStamp() + fromSeconds(mission.robots()[i].start_offset_s));
    EXPECT_TRUE(first.truth.isApprox(Pose3::Identity(), 1e-12));
    EXPECT_TRUE(first.odometry.isApprox(Pose3::Identity(), 1e-12));
  }
}

TEST(Mission, RecordsInTimeOrderAtTheConfiguredRates) {
  const Mission mission(shortMission());
  Recorder recorder;
  mission.record(0, recorder);
  // 2 s: odometry at 0, 0.02, ..., 2.0 s; sweeps starting at 0 .. 1.9 s, each published when
  // it ends.
  EXPECT_EQ(recorder.odometry_.size(), 101U);
  ASSERT_EQ(recorder.scans_.size(), 20U);
  for (size_t i = 0; i < recorder.scans_.size(); ++i) {
    EXPECT_EQ(recorder.scans_[i].stamp, mission.startStamp() + fromSeconds(0.1 * i));
  }
  EXPECT_TRUE(std::is_sorted(recorder.emitted_.begin(), recorder.emitted_.end()));
  EXPECT_LE(recorder.emitted_.back(), mission.endStamp());
  // Ground robot: level base_link on the floor; it moves at the configured speed.
  const auto& last = recorder.odometry_.back();
  EXPECT_NEAR(last.truth.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(last.truth.translation().norm(), 2.0, 0.05);
  EXPECT_NEAR(last.linear_velocity.norm(), 1.0, 0.2);
}

TEST(Mission, SameSeedSameRecordingOtherSeedOther) {
  auto record = [](int seed) {
    MissionParams params = shortMission();
    params.seed = seed;
    const Mission mission(params);
    Recorder recorder;
    mission.record(1, recorder);
    return recorder;
  };
  const Recorder a = record(7);
  const Recorder b = record(7);
  const Recorder c = record(8);
  ASSERT_EQ(a.scans_.size(), b.scans_.size());
  for (size_t i = 0; i < a.scans_.size(); ++i) {
    ASSERT_EQ(a.scans_[i].points.size(), b.scans_[i].points.size());
    for (size_t k = 0; k < a.scans_[i].points.size(); ++k) {
      ASSERT_EQ(a.scans_[i].points[k].x, b.scans_[i].points[k].x);
      ASSERT_EQ(a.scans_[i].points[k].intensity, b.scans_[i].points[k].intensity);
    }
  }
  for (size_t i = 0; i < a.odometry_.size(); ++i) {
    ASSERT_TRUE(a.odometry_[i].odometry.isApprox(b.odometry_[i].odometry, 0.0));
  }
  EXPECT_NE(a.scans_.back().points.front().x, c.scans_.back().points.front().x);

  // Odometry alone (back-end benchmarks): no scans, the very same samples.
  const Mission mission([] {
    MissionParams params = shortMission();
    params.seed = 7;
    return params;
  }());
  Recorder odometry_only;
  mission.record(1, odometry_only, /*scans=*/false);
  EXPECT_TRUE(odometry_only.scans_.empty());
  ASSERT_EQ(odometry_only.odometry_.size(), a.odometry_.size());
  for (size_t i = 0; i < a.odometry_.size(); ++i) {
    ASSERT_TRUE(a.odometry_[i].odometry.isApprox(odometry_only.odometry_[i].odometry, 0.0));
  }
}

TEST(Mission, OverlapControlsHowMuchTeammatesShareTheirPaths) {
  auto mean_shared = [](double overlap) {
    double sum = 0.0;
    for (int seed = 1; seed <= 4; ++seed) {
      MissionParams params;
      params.robots = 4;
      params.duration_s = 240.0;
      params.world.mine_pillars_x = params.world.mine_pillars_y = 8;
      params.overlap = overlap;
      params.seed = seed;
      const Mission mission(params);
      for (const auto& robot : mission.robots()) sum += robot.shared_fraction;
    }
    return sum / 16.0;
  };
  const double apart = mean_shared(0.0);
  const double together = mean_shared(1.0);
  EXPECT_GT(together, apart + 0.15) << "overlap 0: " << apart << ", overlap 1: " << together;
}

TEST(Mission, AerialRobotsChangeHeightWithinTheirRange) {
  MissionParams params = shortMission();
  params.duration_s = 30.0;
  params.lidar.lidar_rate_hz = 1.0;  // few scans: this test is about motion
  params.aerial_robots = 1;
  const Mission mission(params);
  const RobotPlan& drone = mission.robots()[1];
  ASSERT_TRUE(drone.aerial);
  double low = 1e9;
  double high = -1e9;
  for (double t = 0.0; t < 29.0; t += 0.1) {
    const double z = drone.trajectory.poseAt(t).translation().z();
    low = std::min(low, z);
    high = std::max(high, z);
  }
  EXPECT_GE(low, params.aerial_min_height_m - 1e-9);
  EXPECT_LE(high, params.aerial_max_height_m + 1e-9);
  EXPECT_GT(high - low, 0.5);
  // Its odometry frame sits at its start pose, height included.
  EXPECT_NEAR(drone.world_from_odom.translation().z(), drone.trajectory.poseAt(0).translation().z(),
              1e-12);
  EXPECT_FALSE(mission.robots()[0].aerial);
}

}  // namespace
}  // namespace ccir_mapping::core::simulation
