// One robot of a simulated mission: who it is, where it truly starts and how it moves.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/simulation/trajectory.h"

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
  /// Fraction of the robot's path within Mission::kSharedDistanceM (3 m) of a teammate's path.
  double shared_fraction = 0.0;
};

}  // namespace ccir_mapping::core::simulation
