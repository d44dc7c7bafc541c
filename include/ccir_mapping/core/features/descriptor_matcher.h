// Correspondences between the spin images of two keyframes.
#pragma once

#include <utility>
#include <vector>

#include "ccir_mapping/core/features/local_features.h"

namespace ccir_mapping::core::features {

/// Pairs (i in a, j in b) that are each other's nearest descriptor (L2) and pass Lowe's ratio
/// test both ways (nearest distance < ratio x second nearest). FLANN exact kd-tree search.
std::vector<std::pair<int, int>> mutualMatches(const std::vector<SpinImage>& a,
                                               const std::vector<SpinImage>& b, double ratio);

/// Pairs (i in a, j in b) where j is among i's k nearest descriptors or i among j's, each pair
/// once. Where the place repeats (pillars, drifts), the true partner is often not the nearest:
/// RANSAC, not a ratio test, sorts these out.
std::vector<std::pair<int, int>> nearestMatches(const std::vector<SpinImage>& a,
                                                const std::vector<SpinImage>& b, int k);

}  // namespace ccir_mapping::core::features
