#include "ccir_mapping/core/pose_graph/odometry_uncertainty.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace ccir_mapping::core::pose_graph {
namespace {

constexpr double kMinSigmaM = 0.01;
constexpr double kMinSigmaRad = 0.1 * M_PI / 180.0;

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

Covariance6 stepCovariance(const Pose3& step, const OdometryNoise& noise) {
  const double distance = step.translation().norm();
  const double angle = Eigen::AngleAxisd(step.linear()).angle();
  const double sigma_t = std::max(kMinSigmaM, noise.sigma_m_per_m * distance);
  const double sigma_r =
      std::max(kMinSigmaRad, noise.sigma_rad_per_m * distance + noise.sigma_rad_per_rad * angle);
  Covariance6 c = Covariance6::Zero();
  c.diagonal() << Eigen::Vector3d::Constant(sigma_t * sigma_t),
      Eigen::Vector3d::Constant(sigma_r * sigma_r);
  return c;
}

const Covariance6& OdometryUncertainty::advance(const Pose3& pose) {
  if (!started_) {
    started_ = true;
    pose_ = pose;
    return covariance_;
  }
  const Pose3 step = pose_.inverse() * pose;
  // First order: p' = p + R dp and R' = R dR, with the step's own errors in its start frame:
  // dp' = dp - [R dp_step]x dtheta + R e_p and dtheta' = dtheta + R e_theta.
  const Eigen::Matrix3d& r = pose_.linear();
  Covariance6 f = Covariance6::Identity();
  f.topRightCorner<3, 3>() = -skew(r * step.translation());
  Covariance6 g = Covariance6::Zero();
  g.topLeftCorner<3, 3>() = r;
  g.bottomRightCorner<3, 3>() = r;
  covariance_ = f * covariance_ * f.transpose() + g * stepCovariance(step, noise_) * g.transpose();
  pose_ = pose;
  return covariance_;
}

Covariance6 inBodyFrame(const Covariance6& world, const Eigen::Matrix3d& rotation) {
  Covariance6 r = Covariance6::Zero();
  r.topLeftCorner<3, 3>() = rotation.transpose();
  r.bottomRightCorner<3, 3>() = rotation.transpose();
  return r * world * r.transpose();
}

}  // namespace ccir_mapping::core::pose_graph
