// Expectation-maximisation for one Gaussian mixture (algorithms.md section 6.2): k-means++
// seeding with a fixed seed, responsibilities in log space, a covariance floor, components that
// explain less than one point dropped, bounded iterations.
#pragma once

#include <vector>

#include "ccir_mapping/core/hgmm/gaussian_mixture.h"
#include "ccir_mapping/core/hgmm/hgmm_params.h"

namespace ccir_mapping::core::hgmm {

struct EmFit {
  /// Weights sum to 1.
  GaussianMixture mixture;
  /// Mean log-likelihood per point (of the subset EM ran on) before each M-step
  /// (non-decreasing but for the floor).
  std::vector<double> log_likelihoods;
  /// Each point's most likely component of `mixture`.
  std::vector<int> labels;
  /// Mean log-likelihood of all the points under `mixture` (computed with the labels).
  double mean_log_likelihood = 0.0;
};

/// Throws std::invalid_argument for invalid params or no points.
EmFit fitGaussianMixture(const Points& points, const EmParams& params);

}  // namespace ccir_mapping::core::hgmm
