#include "ccir_mapping/core/pose_graph/robust_kernel.h"

#include <array>
#include <utility>

namespace ccir_mapping::core::pose_graph {
namespace {

constexpr std::array<std::pair<RobustKernel, const char*>, 5> kNames{{
    {RobustKernel::kSwitchable, "switchable"},
    {RobustKernel::kNone, "none"},
    {RobustKernel::kCauchy, "cauchy"},
    {RobustKernel::kHuber, "huber"},
    {RobustKernel::kDcs, "dcs"},
}};

}  // namespace

std::optional<RobustKernel> parseRobustKernel(std::string_view text) {
  for (const auto& [kernel, name] : kNames) {
    if (text == name) return kernel;
  }
  return std::nullopt;
}

const char* toString(RobustKernel kernel) {
  for (const auto& [k, name] : kNames) {
    if (k == kernel) return name;
  }
  return "?";
}

}  // namespace ccir_mapping::core::pose_graph
