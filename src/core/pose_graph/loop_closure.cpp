#include "ccir_mapping/core/pose_graph/loop_closure.h"

#include <Eigen/Cholesky>

namespace ccir_mapping::core::pose_graph {

std::optional<std::string> loopClosureProblem(const LoopClosureData& loop) {
  if (loop.robot_from.empty() || loop.robot_to.empty()) return "it names no robot";
  if (!isValidPose(loop.relative)) return "relative pose not finite";
  // LLT does not notice NaN entries.
  if (!loop.covariance.allFinite() ||
      Eigen::LLT<Matrix6>(loop.covariance).info() != Eigen::Success) {
    return "covariance not finite and positive definite";
  }
  if (loop.odom_pose_from && !isValidPose(*loop.odom_pose_from)) {
    return "odom_pose_from not finite";
  }
  if (loop.odom_pose_to && !isValidPose(*loop.odom_pose_to)) return "odom_pose_to not finite";
  return std::nullopt;
}

LoopRoute routeOwnLoop(const std::string& self, const LoopClosureData& loop) {
  if (loop.robot_from != self && loop.robot_to != self) return LoopRoute::kDrop;
  return loop.robot_from == loop.robot_to ? LoopRoute::kUse : LoopRoute::kUseAndForward;
}

LoopRoute routeTeammateLoop(const std::string& self, const LoopClosureData& loop) {
  if (loop.robot_from == self) return LoopRoute::kIgnore;
  const bool teammates_own = loop.robot_to == loop.robot_from;  // never shared
  return loop.odom_pose_from && !teammates_own ? LoopRoute::kUse : LoopRoute::kDrop;
}

}  // namespace ccir_mapping::core::pose_graph
