// Aligning a keyframe's Gaussian mixture with another scan, the two ways of issue 21 (thesis
// section 6.2 and its future work): the thesis's - sample the mixture into a cloud and run GICP
// against the other cloud - and registering the mixtures themselves - GICP over the component
// means with the components' covariances as GICP's (algorithms.md section 6.3), a few hundred
// "points" instead of thousands. Both on PCL's GeneralizedIterativeClosestPoint.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/hgmm/gaussian_mixture.h"

namespace ccir_mapping::core::hgmm {

struct RegistrationParams {
  /// GICP's correspondence gate (PCL's default of 5 m is far too loose, algorithms.md 6.4).
  double max_correspondence_m = 1.0;
  int max_iterations = 50;
  /// The sampled registration is accepted when GICP converged and the mean squared distance of
  /// the moved samples to their nearest target points is at most this.
  double max_fitness_m2 = 0.1;
  /// The mixtures' registration is accepted when GICP converged and the moved source is at
  /// least this similar to the target (similarity(), 1 = the same density). Not the means'
  /// fitness: components ~1 m apart leave ~0.3 m^2 at a true alignment and hardly more at a
  /// wrong one in an aliased mine.
  double min_similarity = 0.15;
  /// Points drawn from the mixture for the sampled registration.
  int samples = 3000;

  std::vector<std::string> validate() const;
};

struct Registration {
  bool accepted = false;
  /// Moves the source into the target's frame.
  Pose3 transform = Pose3::Identity();
  double fitness_m2 = 0.0;
  /// Of the mixtures' registration: similarity(source moved, target).
  double similarity = 0.0;
  std::string reason;  // why it was refused, "" when accepted
};

/// The mixture moved by `pose`: means R mu + t, covariances R S R^T.
GaussianMixture transformed(const GaussianMixture& mixture, const Pose3& pose);

/// GICP of the source's component means onto the target's, each with its covariance. Throws
/// std::invalid_argument on invalid params.
Registration registerMixtures(const GaussianMixture& source, const GaussianMixture& target,
                              const Pose3& guess, const RegistrationParams& params);

/// GICP of params.samples points drawn from `source` onto the `target` cloud (covariances from
/// neighbours, as PCL estimates them).
Registration registerSampled(const GaussianMixture& source, const Points& target,
                             const Pose3& guess, const RegistrationParams& params,
                             std::mt19937_64& rng);

}  // namespace ccir_mapping::core::hgmm
