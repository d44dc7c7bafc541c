#include "ccir_mapping/core/testing/trajectory_error.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

namespace ccir_mapping::core::testing {

double absoluteTrajectoryError(const std::vector<Pose3>& estimate,
                               const std::vector<Pose3>& reference) {
  if (estimate.size() != reference.size() || estimate.size() < 3) {
    throw std::invalid_argument(
        "trajectory error needs two trajectories of the same length >= 3 (" +
        std::to_string(estimate.size()) + " vs " + std::to_string(reference.size()) + ")");
  }
  Eigen::Matrix3Xd from(3, estimate.size());
  Eigen::Matrix3Xd to(3, reference.size());
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    from.col(static_cast<Eigen::Index>(i)) = estimate[i].translation();
    to.col(static_cast<Eigen::Index>(i)) = reference[i].translation();
  }
  const Eigen::Matrix4d alignment = Eigen::umeyama(from, to, false);
  const Eigen::Matrix3Xd aligned =
      (alignment.topLeftCorner<3, 3>() * from).colwise() + alignment.topRightCorner<3, 1>();
  return std::sqrt((aligned - to).colwise().squaredNorm().mean());
}

}  // namespace ccir_mapping::core::testing
