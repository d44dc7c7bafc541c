// A team mission: the world, each robot's route and true motion, and what each robot records
// (scans, odometry, ground truth), all determined by the parameters and their seed.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/simulation/lidar_model.h"
#include "ccir_mapping/core/simulation/mission_params.h"
#include "ccir_mapping/core/simulation/trajectory.h"
#include "ccir_mapping/core/simulation/world.h"

namespace ccir_mapping::core::simulation {

struct RobotPlan {
  std::string name;
  bool aerial = false;
  /// Seconds after the mission start at which the robot starts moving and recording.
  double start_offset_s = 0.0;
  /// True pose of the robot's odometry frame in the world: where base_link starts. Only the
  /// mission file knows it; the robot's own data start at the origin.
  Pose3 world_from_odom = Pose3::Identity();
  /// Road map nodes the robot drives through.
  std::vector<int> route;
  Trajectory trajectory;
  /// Distance driven or flown (xy) during the mission.
  double distance_m = 0.0;
  /// Fraction of the robot's path within kSharedDistanceM of a teammate's path.
  double shared_fraction = 0.0;
};

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

class Mission {
 public:
  static constexpr double kSharedDistanceM = 3.0;

  /// Builds the world and plans every robot. Throws std::invalid_argument naming the first
  /// invalid parameter.
  explicit Mission(const MissionParams& params);

  /// Records robot `index` into `sink`. Depends only on the parameters and the index, so robots
  /// can be recorded in parallel.
  void record(int index, RecordingSink& sink) const;

  const MissionParams& params() const { return params_; }
  const World& world() const { return world_; }
  const std::vector<RobotPlan>& robots() const { return robots_; }
  const LidarModel& lidar() const { return lidar_; }
  Stamp startStamp() const;
  Stamp endStamp() const;
  /// Pose of the lidar in base_link.
  Pose3 sensorMount() const;

  /// "robot_a", "robot_b", ..., "robot_z", "robot_ba", ...
  static std::string robotName(int index);

 private:
  void planRobots();

  MissionParams params_;
  World world_;
  LidarModel lidar_;
  std::vector<RobotPlan> robots_;
};

}  // namespace ccir_mapping::core::simulation
