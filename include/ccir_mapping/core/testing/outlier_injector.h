// False loop closures for robust-back-end benchmarks, following the convention of the
// robust-SLAM literature (Vertigo's generator, described in shared/data/SOURCES.md).
// Written here: the generator is a script outside our libraries, and we need it seeded in C++.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "ccir_mapping/core/pose_graph/pose_graph.h"

namespace ccir_mapping::core::testing {

/// random: uniform pairs i != j, j != i + 1; local: j within `local_window` after i; grouped:
/// groups of `group_size` mutually consistent edges (i + k, j + k) sharing one measurement.
enum class OutlierMode { kRandom, kLocal, kGrouped };
constexpr std::string_view kOutlierModeChoices = "random | local | grouped";
std::optional<OutlierMode> parseOutlierMode(std::string_view text);
const char* toString(OutlierMode mode);

struct OutlierParams {
  int count = 100;
  OutlierMode mode = OutlierMode::kRandom;
  int group_size = 10;
  int local_window = 20;
  /// Measurements: translation ~ N(0, sigma^2) per axis, angles ~ N(0, sigma^2).
  double translation_sigma_m = 0.3;
  double angle_sigma_deg = 10.0;
  /// Only between two robots of a multi-robot graph (graph.keys), a group within each one's
  /// consecutive poses; local mode is then meaningless.
  bool inter_robot = false;
  std::uint64_t seed = 1;
};

/// Appends `params.count` false loop closures (loop = outlier = true) whose information copies
/// the first true loop's (the first edge's when there is none). Deterministic for a seed.
/// Throws std::invalid_argument for a graph too small to hold them (or, inter_robot, of one
/// robot).
void injectOutliers(pose_graph::PoseGraph& graph, const OutlierParams& params);

}  // namespace ccir_mapping::core::testing
