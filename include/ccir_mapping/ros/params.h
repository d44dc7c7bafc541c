// Per-nodelet configuration: the ROS-side settings (robot name, frames, input choices) plus the
// core Params struct, loaded from a ParamReader and validated in one go.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"
#include "ccir_mapping/core/preprocess/lidar_odometry_params.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/transport/bridge_params.h"
#include "ccir_mapping/ros/param_reader.h"

namespace ccir_mapping::ros_params {

/// Frames of one robot; defaults derive from the robot name ("robot_a/odom", ...).
struct RobotFrames {
  std::string robot_name = "robot";
  std::string map_frame;
  std::string odom_frame;
  std::string base_frame;
};

/// Where a robot keeps what outlives its process: the Mapper writes its map (map.bt), the Backend
/// its team graph and trajectories (team_graph.g2o, trajectory.tum, odometry.tum), on their save
/// services, every period_s and, with on_shutdown, when they stop (SIGINT, roslaunch shutdown,
/// unloading); the Preprocessor (keyframe_ids) and the Backend (team_graph_inputs) keep their
/// journals there all along.
struct SaveSettings {
  /// Left empty, load() sets $ROS_HOME/ccir_mapping/<robot_name> (~/.ros without ROS_HOME).
  std::string dir;
  bool on_shutdown = true;  // Mapper and Backend
  /// Mapper and Backend: also save every period_s of mission time (0: only on the services and
  /// at shutdown), so that a robot that dies keeps a recent map to resume.
  double period_s = 0.0;
  /// Continue the mission of a previous run from dir (a robot restarted after a crash): keyframe
  /// ids after those it used, the team graph from its inputs, the map from map.bt. Without it a
  /// run starts a new mission.
  bool resume = false;
};

struct PreprocessorSettings {
  RobotFrames frames;
  /// "topic": nav_msgs/Odometry on `odom` (base_frame in odom_frame); "tf": odom_frame ->
  /// sensor frame from tf; "lidar": the scans themselves (lidar_odometry), broadcast on tf.
  std::string odom_source = "topic";
  /// Scans the velodyne_points subscriber holds while the Preprocessor is busy (roscpp drops
  /// the oldest of a full queue; the Preprocessor counts them as missed): 2 s of a VLP-16,
  /// enough for a manager that a busy machine stalls for a moment.
  int scan_queue_size = 20;
  /// dir and resume only: the keyframe ids' journal.
  SaveSettings save;
  core::preprocess::PreprocessorParams core;
  core::preprocess::LidarOdometryParams lidar_odometry;
};

struct MatcherSettings {
  RobotFrames frames;
  core::place_recognition::MatcherParams core;
};

struct BackendSettings {
  RobotFrames frames;
  /// Broadcast map -> odom (and team transforms) on tf.
  bool publish_tf = true;
  SaveSettings save;
  core::backend::BackendParams core;
};

struct MapperSettings {
  RobotFrames frames;
  SaveSettings save;
  core::information::MapperParams core;
};

struct BrokerSettings {
  RobotFrames frames;
  /// The nodelets of this manager the Broker depends on, by name: the Mapper whose map ranks
  /// requests (mode ccir) and whose parameters size footprints, and the Bridge whose peers it
  /// routes to (robot.launch names them).
  std::string mapper = "mapper";
  std::string bridge = "bridge";
  core::routing::BrokerParams core;
};

struct BridgeSettings {
  RobotFrames frames;
  core::transport::BridgeParams core;
};

/// Each loader reads every key it knows (leaving defaults for absent ones) and validates;
/// problems end up in reader.errors().
void load(ParamReader& reader, PreprocessorSettings& config);
void load(ParamReader& reader, MatcherSettings& config);
void load(ParamReader& reader, BackendSettings& config);
void load(ParamReader& reader, MapperSettings& config);
void load(ParamReader& reader, BrokerSettings& config);
void load(ParamReader& reader, BridgeSettings& config);

}  // namespace ccir_mapping::ros_params
