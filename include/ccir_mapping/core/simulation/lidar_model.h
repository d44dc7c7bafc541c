// A Velodyne VLP-16 model: 16 rings at -15..+15 deg in 2 deg steps, spinning clockwise (seen from
// above) like the real sensor, each firing cast from the sensor pose at its own time.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "ccir_mapping/core/common/lidar_scan.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/simulation/lidar_params.h"
#include "ccir_mapping/core/simulation/world.h"

namespace ccir_mapping::core::simulation {

class LidarModel {
 public:
  static constexpr int kRings = 16;
  /// Sensor pose in the world at `t` seconds after the start of the sweep.
  using PoseAt = std::function<Pose3(double t)>;

  explicit LidarModel(const LidarParams& params);

  /// Elevation of ring r: -15 deg + 2 deg * r.
  static double elevationRad(int ring);
  /// Azimuth of column c in the sensor frame: 0 at +x, decreasing (clockwise) with c.
  double azimuthRad(int column) const;
  double sweepSeconds() const { return 1.0 / params_.lidar_rate_hz; }

  LidarScan scan(const World& world, Stamp stamp, const PoseAt& sensor_pose,
                 std::mt19937_64& rng) const;

  const LidarParams& params() const { return params_; }

 private:
  LidarParams params_;
  /// Unit beam directions in the sensor frame, index column * kRings + ring.
  std::vector<Eigen::Vector3d> directions_;
};

}  // namespace ccir_mapping::core::simulation
