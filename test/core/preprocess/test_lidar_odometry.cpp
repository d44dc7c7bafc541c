// Lidar odometry (core/preprocess/lidar_odometry.h) on a simulated mine drive with truth, and
// what it does with scans it cannot register.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "ccir_mapping/core/preprocess/lidar_odometry.h"
#include "ccir_mapping/core/preprocess/lidar_scan_cloud.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::preprocess {
namespace {

/// The first scans of a one-robot mine mission with the true sensor pose at each.
class Drive : public simulation::RecordingSink {
 public:
  explicit Drive(double duration_s) {
    simulation::MissionParams params;
    params.robots = 1;
    params.duration_s = duration_s;
    const simulation::Mission mission(params);
    mount_ = mission.sensorMount();
    mission.record(0, *this);
  }
  void odometry(const simulation::OdometrySample& s) override { truth_.add(s.stamp, s.truth); }
  void scan(const LidarScan& scan, Stamp) override {
    if (const auto truth = truth_.at(scan.stamp, 0.05)) {
      scans.push_back(scan);
      sensor_truth.push_back(*truth * mount_);
    }
  }
  std::vector<LidarScan> scans;
  std::vector<Pose3> sensor_truth;

 private:
  Pose3 mount_;
  OdometryBuffer truth_;
};

const Drive& drive() {
  static const Drive d(12.0);  // ~11 m at 1 m/s
  return d;
}

TEST(LidarOdometry, FollowsASimulatedDriveWithinCentimetres) {
  const Drive& d = drive();
  ASSERT_GT(d.scans.size(), 100u);
  LidarOdometry odometry({});
  double path = 0.0;
  for (std::size_t i = 0; i < d.scans.size(); ++i) {
    const auto result = odometry.track(d.scans[i].stamp, toCloud(d.scans[i]));
    EXPECT_TRUE(result.registered)
        << "scan " << i << ": " << (result.notice ? result.notice->text : "");
    if (i == 0) EXPECT_TRUE(result.pose.isApprox(Pose3::Identity()));
    if (i > 0) {
      path += (d.sensor_truth[i].translation() - d.sensor_truth[i - 1].translation()).norm();
    }
    const Pose3 truth = d.sensor_truth.front().inverse() * d.sensor_truth[i];
    // Wheel odometry of the simulator drifts ~2 % (0.2 m here); the lidar stays within 1 %.
    ASSERT_LT((result.pose.translation() - truth.translation()).norm(), 0.05 + 0.01 * path)
        << "scan " << i << " after " << path << " m";
    ASSERT_LT(Eigen::AngleAxisd(result.pose.rotation().transpose() * truth.rotation()).angle(),
              0.02)
        << "scan " << i;
  }
  EXPECT_GT(path, 9.0);
  EXPECT_GT(odometry.localMapPoints(), 1000u);
}

TEST(LidarOdometry, AStandingSensorStaysPut) {
  const LidarScan& scan = drive().scans.front();
  LidarOdometry odometry({});
  for (int i = 0; i < 10; ++i) {
    const auto result = odometry.track(fromSeconds(1.0 + 0.1 * i), toCloud(scan));
    EXPECT_TRUE(result.registered);
    EXPECT_LT(result.pose.translation().norm(), 0.01) << i;
  }
}

TEST(LidarOdometry, ScansItCannotRegisterArePredictedAndNamed) {
  const Drive& d = drive();
  LidarOdometry odometry({});
  for (std::size_t i = 0; i < 5; ++i) odometry.track(d.scans[i].stamp, toCloud(d.scans[i]));
  const Pose3 before = odometry.track(d.scans[5].stamp, toCloud(d.scans[5])).pose;

  // A stamp not after the previous one: the previous pose, nothing learnt.
  const auto repeated = odometry.track(d.scans[5].stamp, toCloud(d.scans[5]));
  EXPECT_FALSE(repeated.registered);
  ASSERT_TRUE(repeated.notice);
  EXPECT_EQ(repeated.notice->kind, "lidar odometry stamp");
  EXPECT_TRUE(repeated.pose.isApprox(before));

  // Nothing but NaN and points on the robot: the constant-velocity prediction (moving on).
  LidarOdometry::Cloud useless;
  useless.push_back(pcl::PointXYZI(std::nanf(""), 1.0f, 1.0f, 1.0f));
  for (int i = 0; i < 100; ++i) useless.push_back(pcl::PointXYZI(0.2f, 0.1f, 0.0f, 1.0f));
  const auto empty = odometry.track(d.scans[6].stamp, useless);
  EXPECT_FALSE(empty.registered);
  ASSERT_TRUE(empty.notice);
  EXPECT_EQ(empty.notice->kind, "lidar odometry points");
  EXPECT_GT((empty.pose.translation() - before.translation()).norm(), 0.05);
  EXPECT_LT((empty.pose.translation() - before.translation()).norm(), 0.2);

  // Good scans after it register again, where the truth says.
  const auto next = odometry.track(d.scans[7].stamp, toCloud(d.scans[7]));
  EXPECT_TRUE(next.registered);
  const Pose3 truth = d.sensor_truth.front().inverse() * d.sensor_truth[7];
  EXPECT_LT((next.pose.translation() - truth.translation()).norm(), 0.05);
}

TEST(LidarOdometry, InvalidParametersAreNamed) {
  LidarOdometryParams params;
  params.voxel_m = 0.0;
  params.max_fitness_m2 = std::nan("");
  const auto errors = params.validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].rfind("lidar_voxel_m = 0", 0), 0u) << errors[0];
  EXPECT_EQ(errors[1].rfind("lidar_max_fitness_m2 = nan", 0), 0u) << errors[1];
  EXPECT_THROW(LidarOdometry{params}, std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
