// Writes a simulated mission to disk: one rosbag and one ground-truth file per robot, and
// mission.yaml with the parameters and each robot's true initial pose in the world.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <visualization_msgs/MarkerArray.h>

#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::simulation_io {

enum class BagCompression { kNone, kLz4, kBz2 };

struct BagOptions {
  BagCompression compression = BagCompression::kNone;
  /// Record under /<robot>/ (velodyne_points, odom, ...) for replaying several robots into one
  /// master; by default topics are global, for one master per robot.
  bool namespace_topics = false;
};

/// What was written for one robot.
struct RobotRecording {
  std::string bag_file;
  std::string ground_truth_file;
  std::uint64_t scans = 0;
  std::uint64_t points = 0;
  std::uint64_t odometry_messages = 0;
  std::uint64_t bag_bytes = 0;
};

/// Topics in each robot's bag (prefixed by /<robot> with namespace_topics).
struct BagTopics {
  static constexpr const char* kPoints = "velodyne_points";
  static constexpr const char* kOdometry = "odom";
  static constexpr const char* kGroundTruth = "ground_truth";
  static constexpr const char* kWorld = "sim/world";
};

/// Records robot `index` into DIR/<robot>.bag and DIR/<robot>_gt.txt. Throws std::runtime_error
/// when a file cannot be written.
RobotRecording writeRobotRecording(const core::simulation::Mission& mission, int index,
                                   const std::string& dir, const BagOptions& options);

/// DIR/mission.yaml. `command_line` is recorded so that the mission can be reproduced.
void writeMissionFile(const core::simulation::Mission& mission,
                      const std::vector<RobotRecording>& recordings, const std::string& dir,
                      const std::string& command_line);

/// The world's solids for rviz, expressed in `frame` where frame_from_world places the world.
visualization_msgs::MarkerArray worldMarkers(const core::simulation::World& world,
                                             const std::string& frame,
                                             const core::Pose3& frame_from_world);

}  // namespace ccir_mapping::simulation_io
