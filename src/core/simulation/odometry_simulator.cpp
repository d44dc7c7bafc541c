#include "ccir_mapping/core/simulation/odometry_simulator.h"

#include <cmath>

#include <Eigen/Geometry>

namespace ccir_mapping::core::simulation {

OdometrySimulator::OdometrySimulator(const OdometryParams& params, bool planar, std::uint64_t seed)
    : params_(params), planar_(planar), rng_(seed) {}

const Pose3& OdometrySimulator::update(const Pose3& truth) {
  if (!started_) {
    started_ = true;
    last_truth_ = truth;
    estimate_ = truth;
    return estimate_;
  }
  Pose3 increment = last_truth_.inverse() * truth;
  last_truth_ = truth;
  if (!params_.noiseFree()) {
    // Random walks: variance grows linearly with distance and turned angle, so the spread after
    // a path does not depend on how finely it is sampled.
    const double distance = increment.translation().norm();
    const Eigen::Matrix3d& r = increment.linear();
    const double turned = std::abs(std::atan2(r(1, 0), r(0, 0)));
    const double position_sigma = params_.odom_noise_m_per_m * std::sqrt(distance);
    const double heading_variance =
        params_.odom_noise_rad_per_m * params_.odom_noise_rad_per_m * distance +
        params_.odom_noise_rad_per_rad * params_.odom_noise_rad_per_rad * turned;
    Eigen::Vector3d position_error = Eigen::Vector3d::Zero();  // drawn in order x, y, z
    for (int axis = 0; axis < (planar_ ? 2 : 3); ++axis) position_error[axis] = normal_(rng_);
    increment.translation() += position_sigma * position_error;
    increment.linear() =
        r * Eigen::AngleAxisd(std::sqrt(heading_variance) * normal_(rng_), Eigen::Vector3d::UnitZ())
                .toRotationMatrix();
    position_variance_ += position_sigma * position_sigma;
    heading_variance_ += heading_variance;
  }
  estimate_ = estimate_ * increment;
  return estimate_;
}

}  // namespace ccir_mapping::core::simulation
