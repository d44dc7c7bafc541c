// Drifting odometry: integrates the true motion increments with random-walk errors.
#pragma once

#include <random>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/simulation/odometry_params.h"

namespace ccir_mapping::core::simulation {

class OdometrySimulator {
 public:
  /// `planar`: ground robots get no height error.
  OdometrySimulator(const OdometryParams& params, bool planar, std::uint64_t seed);

  /// Takes the next true pose of base_link in the odometry frame (the first call sets the start)
  /// and returns the odometry's estimate of it.
  const Pose3& update(const Pose3& truth);

  /// Variances accumulated so far: position per axis (m^2) and heading (rad^2).
  double positionVariance() const { return position_variance_; }
  double headingVariance() const { return heading_variance_; }

 private:
  OdometryParams params_;
  bool planar_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  bool started_ = false;
  Pose3 last_truth_ = Pose3::Identity();
  Pose3 estimate_ = Pose3::Identity();
  double position_variance_ = 0.0;
  double heading_variance_ = 0.0;
};

}  // namespace ccir_mapping::core::simulation
