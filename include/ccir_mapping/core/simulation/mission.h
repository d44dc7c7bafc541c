// A team mission: the world, each robot's route and true motion, and what each robot records
// (scans, odometry, ground truth), all determined by the parameters and their seed.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/simulation/lidar_model.h"
#include "ccir_mapping/core/simulation/mission_params.h"
#include "ccir_mapping/core/simulation/recording_sink.h"
#include "ccir_mapping/core/simulation/robot_plan.h"
#include "ccir_mapping/core/simulation/world.h"

namespace ccir_mapping::core::simulation {

class Mission {
 public:
  static constexpr double kSharedDistanceM = 3.0;

  /// Builds the world and plans every robot. Throws std::invalid_argument naming the first
  /// invalid parameter.
  explicit Mission(const MissionParams& params);

  /// Records robot `index` into `sink`. Depends only on the parameters and the index, so robots
  /// can be recorded in parallel. Without `scans` only the odometry (the same samples) is
  /// recorded: what a back-end benchmark needs, without the cost of ray casting.
  void record(int index, RecordingSink& sink, bool scans = true) const;

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
