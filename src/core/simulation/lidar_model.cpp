#include "ccir_mapping/core/simulation/lidar_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::simulation {
namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

LidarModel::LidarModel(const LidarParams& params) : params_(validated(params)) {
  directions_.reserve(static_cast<size_t>(params.lidar_columns) * kRings);
  for (int c = 0; c < params.lidar_columns; ++c) {
    const double azimuth = azimuthRad(c);
    for (int r = 0; r < kRings; ++r) {
      const double elevation = elevationRad(r);
      directions_.emplace_back(std::cos(elevation) * std::cos(azimuth),
                               std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    }
  }
}

double LidarModel::elevationRad(int ring) { return (-15.0 + 2.0 * ring) * kPi / 180.0; }

double LidarModel::azimuthRad(int column) const {
  return -2.0 * kPi * column / params_.lidar_columns;
}

LidarScan LidarModel::scan(const World& world, Stamp stamp, const PoseAt& sensor_pose,
                           std::mt19937_64& rng) const {
  const int columns = params_.lidar_columns;
  LidarScan scan;
  scan.stamp = stamp;
  scan.organized = params_.lidar_organized;
  scan.columns = columns;
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  if (scan.organized) {
    scan.points.assign(static_cast<size_t>(kRings) * columns,
                       LidarPoint{kNaN, kNaN, kNaN, 0.0F, 0, 0.0F});
  } else {
    scan.points.reserve(static_cast<size_t>(kRings) * columns);
  }
  std::normal_distribution<double> range_noise(0.0, params_.lidar_range_noise_m);
  const bool noisy = params_.lidar_range_noise_m > 0.0;

  for (int c = 0; c < columns; ++c) {
    const double t = sweepSeconds() * c / columns;
    const Pose3 pose = sensor_pose(t);
    const Eigen::Matrix3d rotation = pose.linear();
    if (scan.organized) {
      for (int r = 0; r < kRings; ++r) {
        auto& slot = scan.points[static_cast<size_t>(r) * columns + c];
        slot.ring = static_cast<std::uint16_t>(r);
        slot.time = static_cast<float>(t);
      }
    }
    for (int r = 0; r < kRings; ++r) {
      const Eigen::Vector3d& direction = directions_[static_cast<size_t>(c) * kRings + r];
      const Ray ray{pose.translation(), rotation * direction};
      const auto hit = world.castRay(ray, params_.lidar_max_range_m);
      if (!hit) continue;
      // Draw noise only for returns, so that a beam's noise does not depend on others' misses.
      const double range = hit->range + (noisy ? range_noise(rng) : 0.0);
      if (range < params_.lidar_min_range_m || range > params_.lidar_max_range_m) continue;
      // Diffuse reflectivity scaled by the incidence angle, on the driver's 0..100 scale.
      const double incidence = std::abs(hit->normal.dot(ray.direction));
      const auto intensity =
          static_cast<float>(100.0 * hit->reflectivity * (0.3 + 0.7 * incidence));
      const Eigen::Vector3d p = range * direction;
      const LidarPoint point{static_cast<float>(p.x()),     static_cast<float>(p.y()),
                             static_cast<float>(p.z()),     intensity,
                             static_cast<std::uint16_t>(r), static_cast<float>(t)};
      if (scan.organized) {
        scan.points[static_cast<size_t>(r) * columns + c] = point;
      } else {
        scan.points.push_back(point);
      }
    }
  }
  return scan;
}

}  // namespace ccir_mapping::core::simulation
