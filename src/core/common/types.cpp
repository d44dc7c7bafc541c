#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core {

bool isValidPose(const Pose3& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = pose.linear();
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         std::abs(r.determinant() - 1.0) < 1e-6;
}

}  // namespace ccir_mapping::core
