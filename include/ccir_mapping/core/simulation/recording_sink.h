// What a simulated robot records, delivered in time order.
#pragma once

#include "ccir_mapping/core/common/lidar_scan.h"
#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::simulation {

/// One odometry message's worth: the estimate, the truth and what a driver would also report.
struct OdometrySample {
  Stamp stamp = 0;
  Pose3 odometry = Pose3::Identity();
  Pose3 truth = Pose3::Identity();
  /// True velocity in base_link (encoders measure speed well; the drift is in the pose).
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  double yaw_rate = 0.0;
  double position_variance = 0.0;
  double heading_variance = 0.0;
};

/// Receives a robot's recording in time order.
class RecordingSink {
 public:
  virtual ~RecordingSink() = default;
  virtual void odometry(const OdometrySample& sample) = 0;
  /// A scan is delivered when its sweep ends, at `published`, as a driver publishes it.
  virtual void scan(const LidarScan& scan, Stamp published) = 0;
};

}  // namespace ccir_mapping::core::simulation
