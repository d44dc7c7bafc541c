// How uncertain a pose integrated from odometry is: the covariance each step adds (the same
// model weights the Backend's odometry edges) and its propagation along a chain of keyframes,
// so that a loop closure seen after long drift is judged against the drift (Dong et al.'s pose
// uncertainty in the team-transform EM).
#pragma once

#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::pose_graph {

using Covariance6 = Eigen::Matrix<double, 6, 6>;

struct OdometryNoise {
  /// Standard deviation per metre travelled: position (per axis) and heading.
  double sigma_m_per_m = 0.05;
  double sigma_rad_per_m = 0.01;
  /// Heading standard deviation per radian turned.
  double sigma_rad_per_rad = 0.05;
};

/// Covariance of one odometry step, tangent [x y z, rotation vector] in the step's start frame:
/// standard deviations in proportion to its length (heading also to its turn), at least 1 cm and
/// 0.1 deg so that short steps are not over-confident.
Covariance6 stepCovariance(const Pose3& step, const OdometryNoise& noise);

/// Covariance of the poses along one odometry chain, in the world frame: a pose's error is
/// [dp, dtheta] with true position p + dp and true rotation Exp(dtheta) R. Its first pose is
/// exact (the frame's origin).
class OdometryUncertainty {
 public:
  explicit OdometryUncertainty(const OdometryNoise& noise) : noise_(noise) {}

  /// Moves on to `pose` from the previous one (or starts the chain there); returns its
  /// covariance.
  const Covariance6& advance(const Pose3& pose);
  const Covariance6& covariance() const { return covariance_; }

 private:
  OdometryNoise noise_;
  bool started_ = false;
  Pose3 pose_ = Pose3::Identity();
  Covariance6 covariance_ = Covariance6::Zero();
};

/// A world-frame covariance ([dp, dtheta] as above) of a pose with rotation `rotation`,
/// expressed in that pose's own frame: what a pose-graph residual at the pose sees.
Covariance6 inBodyFrame(const Covariance6& world, const Eigen::Matrix3d& rotation);

}  // namespace ccir_mapping::core::pose_graph
