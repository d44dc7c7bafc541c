// How loop closures enter the pose graph.
#pragma once

#include <optional>
#include <string_view>

namespace ccir_mapping::core::pose_graph {

/// Switchable constraints (default), plain least squares, Ceres' Cauchy or Huber losses, or
/// dynamic covariance scaling.
enum class RobustKernel { kSwitchable, kNone, kCauchy, kHuber, kDcs };
constexpr std::string_view kRobustKernelChoices = "switchable | none | cauchy | huber | dcs";
std::optional<RobustKernel> parseRobustKernel(std::string_view text);
const char* toString(RobustKernel kernel);

}  // namespace ccir_mapping::core::pose_graph
