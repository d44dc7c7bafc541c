// Robot motion and odometry: constant speed on lanes, rounded corners, turns on the spot,
// odometry that equals the truth without noise and drifts with the configured spread.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/simulation/odometry_simulator.h"
#include "ccir_mapping/core/simulation/trajectory.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;

double yawOf(const Pose3& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

TEST(Trajectory, StraightLaneAtConstantSpeed) {
  const Trajectory line({{0, 0}, {10, 0}}, {2.0, 1.0, 0.8}, nullptr);
  EXPECT_NEAR(line.durationS(), 5.0, 1e-12);
  EXPECT_NEAR(line.lengthM(), 10.0, 1e-12);
  EXPECT_NEAR(line.poseAt(1.5).translation().x(), 3.0, 1e-12);
  EXPECT_NEAR(line.poseAt(-1.0).translation().x(), 0.0, 1e-12);   // waits at the start
  EXPECT_NEAR(line.poseAt(99.0).translation().x(), 10.0, 1e-12);  // stays at the end
  EXPECT_NEAR(line.poseAt(1.0).translation().z(), 0.0, 1e-12);
}

TEST(Trajectory, CornersAreRoundedArcs) {
  const double radius = 1.0;
  const Trajectory corner({{0, 0}, {10, 0}, {10, 10}}, {1.0, radius, 0.8}, nullptr);
  // The arc replaces 2 r of straight lane with a quarter circle.
  EXPECT_NEAR(corner.lengthM(), 20.0 - 2 * radius + kPi / 2 * radius, 1e-9);
  double closest = 1e9;
  Eigen::Vector3d previous = corner.poseAt(0.0).translation();
  double previous_yaw = 0.0;
  for (double t = 0.01; t <= corner.durationS(); t += 0.01) {
    const Pose3 pose = corner.poseAt(t);
    // Continuous at walking speed, heading never jumps.
    ASSERT_LE((pose.translation() - previous).norm(), 0.01 + 1e-9);
    ASSERT_LE(std::abs(yawOf(pose) - previous_yaw), 0.011);
    closest = std::min(closest, (pose.translation().head<2>() - Eigen::Vector2d(10, 0)).norm());
    previous = pose.translation();
    previous_yaw = yawOf(pose);
  }
  EXPECT_NEAR(closest, radius * (std::sqrt(2.0) - 1.0), 1e-3);
  EXPECT_NEAR(yawOf(corner.poseAt(corner.durationS())), kPi / 2, 1e-9);
}

TEST(Trajectory, DeadEndsTurnOnTheSpot) {
  const Trajectory u_turn({{0, 0}, {5, 0}, {0, 0}}, {1.0, 1.0, 0.5}, nullptr);
  EXPECT_NEAR(u_turn.durationS(), 10.0 + kPi / 0.5, 1e-9);
  const Pose3 mid_turn = u_turn.poseAt(5.0 + 0.5 * kPi / 0.5);
  EXPECT_NEAR(mid_turn.translation().x(), 5.0, 1e-12);
  EXPECT_NEAR(std::abs(yawOf(mid_turn)), kPi / 2, 1e-9);
}

TEST(Trajectory, HeightProfileAndBadInput) {
  const Trajectory flying({{0, 0}, {10, 0}}, {1.0, 1.0, 0.8}, [](double t) { return 1.0 + t; });
  EXPECT_NEAR(flying.poseAt(2.0).translation().z(), 3.0, 1e-12);
  EXPECT_THROW(Trajectory({{1, 1}, {1, 1}}, {1.0, 1.0, 0.8}, nullptr), std::invalid_argument);
  EXPECT_THROW(Trajectory({{0, 0}, {1, 1}}, {0.0, 1.0, 0.8}, nullptr), std::invalid_argument);
}

Pose3 planar(double x, double y, double yaw) {
  Pose3 pose = Pose3::Identity();
  pose.translation() << x, y, 0.0;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

TEST(Odometry, WithoutNoiseEqualsTruth) {
  OdometryParams params;
  params.odom_noise_m_per_m = params.odom_noise_rad_per_m = params.odom_noise_rad_per_rad = 0.0;
  OdometrySimulator odometry(params, true, 1);
  const Trajectory path({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {1.0, 1.0, 0.8}, nullptr);
  for (double t = 0.0; t <= path.durationS(); t += 0.02) {
    const Pose3 truth = path.poseAt(t);
    const Pose3 estimate = odometry.update(truth);
    ASSERT_LT((estimate.translation() - truth.translation()).norm(), 1e-9);
    ASSERT_LT((estimate.linear() - truth.linear()).norm(), 1e-9);
  }
  EXPECT_EQ(odometry.positionVariance(), 0.0);
}

/// Error of the odometry over one segment, in the frame of the segment's start.
struct SegmentError {
  double along, across, heading;
};

/// Runs `segments` independent segments of `steps` increments (each `step` in the robot frame)
/// and returns the errors the odometry accumulates over each.
std::vector<SegmentError> segmentErrors(const OdometryParams& params, const Pose3& step, int steps,
                                        int segments) {
  OdometrySimulator odometry(params, true, 7);
  Pose3 truth = Pose3::Identity();
  odometry.update(truth);
  std::vector<SegmentError> errors;
  for (int s = 0; s < segments; ++s) {
    const Pose3 truth_start = truth;
    const Pose3 odom_start = odometry.update(truth);
    Pose3 odom_end = odom_start;
    for (int k = 0; k < steps; ++k) {
      truth = truth * step;
      odom_end = odometry.update(truth);
    }
    const Pose3 true_motion = truth_start.inverse() * truth;
    const Pose3 odom_motion = odom_start.inverse() * odom_end;
    const Pose3 error = true_motion.inverse() * odom_motion;
    errors.push_back({error.translation().x(), error.translation().y(), yawOf(error)});
  }
  return errors;
}

double spread(const std::vector<SegmentError>& errors, double SegmentError::*field) {
  double sum = 0.0;
  double sum2 = 0.0;
  for (const auto& e : errors) {
    sum += e.*field;
    sum2 += (e.*field) * (e.*field);
  }
  const double mean = sum / errors.size();
  return std::sqrt(sum2 / errors.size() - mean * mean);
}

TEST(Odometry, DriftPerMetreMatchesTheConfiguredNoise) {
  OdometryParams params;
  params.odom_noise_m_per_m = 0.02;
  params.odom_noise_rad_per_m = 0.005;
  params.odom_noise_rad_per_rad = 0.0;
  // 1 m segments of 50 steps of 2 cm.
  const auto errors = segmentErrors(params, planar(0.02, 0.0, 0.0), 50, 4000);
  EXPECT_NEAR(spread(errors, &SegmentError::along), 0.02, 0.02 * 0.08);
  EXPECT_NEAR(spread(errors, &SegmentError::heading), 0.005, 0.005 * 0.08);
  // Across-track error also collects the heading error's lever arm (~ 0.005 / sqrt(3) m).
  EXPECT_NEAR(spread(errors, &SegmentError::across), std::hypot(0.02, 0.005 / std::sqrt(3.0)),
              0.02 * 0.1);

  // The spread does not depend on the odometry rate: the same metre in 10 steps of 10 cm.
  const auto coarse = segmentErrors(params, planar(0.1, 0.0, 0.0), 10, 4000);
  EXPECT_NEAR(spread(coarse, &SegmentError::along), 0.02, 0.02 * 0.08);
}

TEST(Odometry, DriftPerRadianMatchesTheConfiguredNoise) {
  OdometryParams params;
  params.odom_noise_m_per_m = 0.0;
  params.odom_noise_rad_per_m = 0.0;
  params.odom_noise_rad_per_rad = 0.02;
  // Turning on the spot, 1 rad per segment in 50 steps.
  const auto errors = segmentErrors(params, planar(0.0, 0.0, 0.02), 50, 4000);
  EXPECT_NEAR(spread(errors, &SegmentError::heading), 0.02, 0.02 * 0.08);
  EXPECT_NEAR(spread(errors, &SegmentError::along), 0.0, 1e-12);
}

}  // namespace
}  // namespace ccir_mapping::core::simulation
