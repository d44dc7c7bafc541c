// Absolute trajectory error after the rigid alignment that minimises it (Umeyama, no scale).
#pragma once

#include <vector>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::testing {

/// RMSE of positions of `estimate` against `reference` (same length, >= 3 poses) after aligning
/// the estimate rigidly onto the reference; throws std::invalid_argument otherwise.
double absoluteTrajectoryError(const std::vector<Pose3>& estimate,
                               const std::vector<Pose3>& reference);

}  // namespace ccir_mapping::core::testing
