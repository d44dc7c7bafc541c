// A verified relative pose between two keyframes, and what a robot does with one: whether it can
// enter a pose graph, and whether it is this robot's to use, to forward to its teammates, or
// another pair's business.
#pragma once

#include <optional>
#include <string>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::pose_graph {

struct LoopClosureData {
  std::string robot_from;
  KeyframeId keyframe_from = 0;
  std::string robot_to;
  KeyframeId keyframe_to = 0;
  /// Pose of keyframe "to" in keyframe "from"'s frame, covariance over [x y z, rotation].
  Pose3 relative = Pose3::Identity();
  Matrix6 covariance = Matrix6::Identity();
  /// Keyframe "from"'s odometry pose, when the robot that found the closure sent it along.
  std::optional<Pose3> odom_pose_from;
  /// Keyframe "to"'s odometry pose (a teammate's, as the finder received it), when known.
  std::optional<Pose3> odom_pose_to;
  /// How the finder found and verified it, for reports (the graph weighs the covariance): the
  /// place-recognition score, the registration's mean squared distance (m^2) and inliers, and
  /// the method ("fabmap", "histogram" or "scan_context").
  double match_score = 0.0;
  /// FAB-MAP's p(new place) for the query the closure was found with; -1: the method has none.
  double new_place_probability = -1.0;
  double fitness_m2 = 0.0;
  int inliers = 0;
  std::string method;
};

/// Why `loop` cannot enter a pose graph, or nullopt: a robot not named, a relative pose that is
/// not a finite rigid transform, a covariance that is not finite and positive definite.
std::optional<std::string> loopClosureProblem(const LoopClosureData& loop);

enum class LoopRoute {
  kUse,            ///< into this robot's graph
  kUseAndForward,  ///< into the graph and to the teammates: an inter-robot closure it found
  kIgnore,         ///< between two other robots, or found by this robot itself
  kDrop,           ///< not what its source may send (warned about and counted)
};

/// A closure this robot's Matcher found: it must involve this robot; an inter-robot one also
/// goes to the teammates (each robot verifies only the scans it received, so without them the
/// two robots of a pair would each see a part of its closures).
LoopRoute routeOwnLoop(const std::string& self, const LoopClosureData& loop);

/// A closure a teammate found and sent (its own keyframe is "from"): used when it joins that
/// teammate to this robot or to another teammate (the team graph holds the whole team's),
/// ignored when it is this robot's own coming back; dropped without the finder's keyframe pose,
/// which this robot may not have, or when it is within the teammate (never shared).
LoopRoute routeTeammateLoop(const std::string& self, const LoopClosureData& loop);

}  // namespace ccir_mapping::core::pose_graph
