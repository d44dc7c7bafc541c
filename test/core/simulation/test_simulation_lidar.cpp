// The simulated VLP-16: ring elevations, 1800 clockwise azimuths, ranges to a known wall, noise,
// dropped and organised no-returns, firing times.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "ccir_mapping/core/simulation/lidar_model.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A closed 20 x 20 x 10 m room centred on the origin.
World room() {
  World world("room", 0.0, 10.0);
  world.add(Box::upright({10.5, 0}, {1, 22}, 0.0, -1, 11, 0.5F));
  world.add(Box::upright({-10.5, 0}, {1, 22}, 0.0, -1, 11, 0.5F));
  world.add(Box::upright({0, 10.5}, {22, 1}, 0.0, -1, 11, 0.5F));
  world.add(Box::upright({0, -10.5}, {22, 1}, 0.0, -1, 11, 0.5F));
  world.buildIndex(2.0);
  return world;
}

LidarModel::PoseAt fixedAt(const Eigen::Vector3d& position) {
  return [position](double) {
    Pose3 pose = Pose3::Identity();
    pose.translation() = position;
    return pose;
  };
}

LidarParams noiseless() {
  LidarParams params;
  params.lidar_range_noise_m = 0.0;
  return params;
}

TEST(Lidar, RingsColumnsAndFiringTimes) {
  const LidarModel lidar(noiseless());
  std::mt19937_64 rng(1);
  const LidarScan scan = lidar.scan(room(), 42, fixedAt({0, 0, 5}), rng);
  EXPECT_EQ(scan.stamp, 42);
  ASSERT_EQ(scan.points.size(), 16U * 1800U);  // a closed room returns every beam
  std::set<long> azimuths;
  for (size_t k = 0; k < scan.points.size(); ++k) {
    const LidarPoint& p = scan.points[k];
    const int column = static_cast<int>(k / 16);
    ASSERT_EQ(p.ring, k % 16);  // column by column, rings in order
    const double elevation = std::atan2(p.z, std::hypot(p.x, p.y)) * 180.0 / kPi;
    ASSERT_NEAR(elevation, -15.0 + 2.0 * p.ring, 1e-3);
    // Clockwise from +x in 0.2 deg steps, as the real sensor spins.
    const double azimuth = std::atan2(p.y, p.x) * 180.0 / kPi;
    const double expected = -0.2 * column;
    ASSERT_NEAR(std::remainder(azimuth - expected, 360.0), 0.0, 1e-3) << "column " << column;
    azimuths.insert(std::lround(std::remainder(azimuth, 360.0) * 10.0));
    ASSERT_NEAR(p.time, 0.1 * column / 1800.0, 1e-7);
    ASSERT_GE(p.intensity, 0.0F);
  }
  EXPECT_EQ(azimuths.size(), 1800U);
  EXPECT_LT(scan.points.back().time, 0.1F);
}

TEST(Lidar, RangeToAKnownWallIsExactWithoutNoise) {
  const LidarModel lidar(noiseless());
  std::mt19937_64 rng(1);
  const LidarScan scan = lidar.scan(room(), 0, fixedAt({0, 0, 5}), rng);
  int checked = 0;
  for (const LidarPoint& p : scan.points) {
    const double elevation = LidarModel::elevationRad(p.ring);
    const double azimuth = std::atan2(p.y, p.x);
    if (std::abs(azimuth) > 0.7) continue;  // beams that meet the wall at x = 10
    const double expected = 10.0 / (std::cos(elevation) * std::cos(azimuth));
    const double range = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    ASSERT_NEAR(range, expected, 1e-4);
    ASSERT_NEAR(p.x, 10.0, 1e-4);
    ++checked;
  }
  EXPECT_GT(checked, 16 * 300);
}

TEST(Lidar, RangeNoiseHasTheConfiguredSpread) {
  LidarParams params;
  params.lidar_range_noise_m = 0.03;
  const LidarModel lidar(params);
  std::mt19937_64 rng(2);
  const LidarScan scan = lidar.scan(room(), 0, fixedAt({0, 0, 5}), rng);
  double sum = 0.0;
  double sum2 = 0.0;
  int n = 0;
  for (const LidarPoint& p : scan.points) {
    const double azimuth = std::atan2(p.y, p.x);
    if (std::abs(azimuth) > 0.7) continue;
    const double elevation = LidarModel::elevationRad(p.ring);
    const double error = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z) -
                         10.0 / (std::cos(elevation) * std::cos(azimuth));
    sum += error;
    sum2 += error * error;
    ++n;
  }
  const double mean = sum / n;
  EXPECT_NEAR(mean, 0.0, 0.003);
  EXPECT_NEAR(std::sqrt(sum2 / n - mean * mean), 0.03, 0.003);
}

TEST(Lidar, BeamsWithoutReturnAreDroppedOrNaN) {
  // Floor only in reach: the 8 upward rings see nothing within 100 m.
  World open("open", 0.0, 500.0);
  open.buildIndex(2.0);
  std::mt19937_64 rng(3);
  const LidarScan dropped = LidarModel(noiseless()).scan(open, 0, fixedAt({0, 0, 1}), rng);
  EXPECT_EQ(dropped.points.size(), 8U * 1800U);
  EXPECT_FALSE(dropped.organized);
  for (const LidarPoint& p : dropped.points) ASSERT_LT(p.ring, 8);

  LidarParams organized_params = noiseless();
  organized_params.lidar_organized = true;
  const LidarScan organized = LidarModel(organized_params).scan(open, 0, fixedAt({0, 0, 1}), rng);
  ASSERT_TRUE(organized.organized);
  ASSERT_EQ(organized.points.size(), 16U * 1800U);
  int nan = 0;
  for (int ring = 0; ring < 16; ++ring) {
    for (int column = 0; column < 1800; ++column) {
      const LidarPoint& p = organized.points[static_cast<size_t>(ring) * 1800 + column];
      ASSERT_EQ(p.ring, ring);  // row = ring, as the driver's organised cloud
      ASSERT_EQ(std::isnan(p.x), ring >= 8);
      nan += std::isnan(p.x);
    }
  }
  EXPECT_EQ(nan, 8 * 1800);
}

TEST(Lidar, MinAndMaxRangeDropReturns) {
  LidarParams params = noiseless();
  params.lidar_max_range_m = 10.5;  // only beams close to the walls' normals come back
  std::mt19937_64 rng(4);
  const LidarScan scan = LidarModel(params).scan(room(), 0, fixedAt({0, 0, 5}), rng);
  ASSERT_FALSE(scan.points.empty());
  for (const LidarPoint& p : scan.points) {
    ASSERT_LE(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z), 10.5);
  }
  EXPECT_LT(scan.points.size(), 16U * 1800U / 2);
}

TEST(Lidar, EachFiringUsesThePoseAtItsTime) {
  // Moving at 1 m/s along +x during the 0.1 s sweep: the wall at x = 10 straight ahead is seen
  // at the start, straight behind (x = -10) half a sweep later, 5 cm further on.
  const LidarModel lidar(noiseless());
  std::mt19937_64 rng(5);
  const auto moving = [](double t) {
    Pose3 pose = Pose3::Identity();
    pose.translation() << t, 0.0, 5.0;
    return pose;
  };
  const LidarScan scan = lidar.scan(room(), 0, moving, rng);
  const LidarPoint& ahead = scan.points[7];              // column 0, ring 7 (-1 deg)
  const LidarPoint& behind = scan.points[900 * 16 + 7];  // column 900: azimuth 180 deg
  EXPECT_NEAR(ahead.x, 10.0, 1e-4);
  EXPECT_NEAR(behind.x, -10.05, 1e-4);
  EXPECT_NEAR(behind.time, 0.05, 1e-6);
}

TEST(Lidar, SameRandomStateSameScan) {
  LidarParams params;
  const LidarModel lidar(params);
  std::mt19937_64 a(9);
  std::mt19937_64 b(9);
  const LidarScan first = lidar.scan(room(), 0, fixedAt({1, 2, 3}), a);
  const LidarScan second = lidar.scan(room(), 0, fixedAt({1, 2, 3}), b);
  ASSERT_EQ(first.points.size(), second.points.size());
  for (size_t i = 0; i < first.points.size(); ++i) ASSERT_EQ(first.points[i].x, second.points[i].x);
}

}  // namespace
}  // namespace ccir_mapping::core::simulation
