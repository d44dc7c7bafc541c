// Parameters of Gaussian-mixture fitting (EM) and of the hierarchy built from it
// (algorithms.md section 6.2).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ccir_mapping::core::hgmm {

struct EmParams {
  /// Components fitted (fewer when there are fewer points).
  int components = 8;
  /// EM stops after this many iterations or when the mean log-likelihood per point improves by
  /// less than `tolerance`.
  int max_iterations = 50;
  double tolerance = 1e-3;
  /// Added to every covariance's diagonal, m^2: keeps the planar and linear clusters of a
  /// 16-ring scan invertible ((1 cm)^2, about the sensor's noise).
  double covariance_floor_m2 = 1e-4;
  /// Beyond this many points EM runs on a seeded random subset of them (its cost grows with
  /// points x components x iterations); every point is still labelled.
  int max_points = 2000;
  /// k-means++ seeding and the subset.
  std::uint64_t seed = 1;

  std::vector<std::string> validate() const;
};

struct HgmmParams {
  /// Each node's children are one EM fit of `em.components` Gaussians to the node's points.
  EmParams em;
  /// Levels below the root mixture (level 0 has em.components Gaussians).
  int max_depth = 3;
  /// A node with fewer points is not split (algorithms.md: ~10 points per child).
  int min_points_to_split = 80;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::hgmm
