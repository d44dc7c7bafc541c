// The transform between two robots' frames from candidate inter-robot loop closures, most of
// them possibly false: uncertainty-aware EM (Dong et al., ICRA 2015, after Indelman et al., ICRA
// 2014) started from k-means clusters of the transforms the candidates imply.
// The EM is written here (no library has it); the clusters are OpenCV's k-means.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::alignment {

using core::Matrix6;

/// One candidate: robot a's keyframe pose x^a_i, robot b's x^b_j (each in its own robot's
/// frame), and the measured pose z of b's keyframe in a's keyframe frame.
struct AlignmentCandidate {
  Pose3 pose_a = Pose3::Identity();
  Pose3 pose_b = Pose3::Identity();
  Pose3 measurement = Pose3::Identity();
  /// Of the measurement, tangent [x y z, rotation vector].
  Matrix6 covariance = Matrix6::Identity();
  /// Marginal covariances of the two local poses (zero when unknown): with them a true loop seen
  /// after long drift still counts as an inlier.
  Matrix6 covariance_a = Matrix6::Zero();
  Matrix6 covariance_b = Matrix6::Zero();
};

struct AlignmentParams {
  /// Estimate x y z yaw only (both robots' frames gravity-aligned), or the full 6 DoF.
  bool four_dof = true;
  /// Fewer inliers than this never make a transform: a small consistent group of false
  /// candidates (perceptual aliasing) must not.
  int min_inliers = 10;
  /// The winner needs this many more inliers than the best distinct runner-up.
  int min_inlier_margin = 3;
  /// Prior probability that a candidate is an inlier.
  double inlier_prior = 0.3;
  /// Outliers are uniform over a cube of this side (and all rotations).
  double outlier_extent_m = 200.0;
  /// Add the local poses' covariances to each candidate's (Dong et al.'s contribution).
  bool use_pose_uncertainty = true;
  int max_iterations = 50;
  /// Metres per radian of yaw when clustering the implied transforms.
  double cluster_yaw_scale_m = 5.0;
  /// Besides k-means centres, EM starts from the candidates most others agree with, counted
  /// for at most this many candidates (evenly spread over them).
  int max_support_starts = 256;
  /// Wall time after which no further EM start is run (the best supported one always is);
  /// 0: no bound.
  double max_time_s = 0.0;
  int seed = 1;

  std::vector<std::string> validate() const;
};

struct AlignmentResult {
  bool found = false;
  /// T^a_b: robot b's frame in robot a's.
  Pose3 transform = Pose3::Identity();
  /// Of the transform, tangent [x y z, rotation vector] (yaw only in 4 DoF).
  Matrix6 covariance = Matrix6::Zero();
  /// Inlier probability of each candidate; inliers[k] = weights[k] > 0.5.
  std::vector<double> weights;
  std::vector<bool> inliers;
  int inlier_count = 0;
  int runner_up_inliers = 0;
  double log_likelihood = 0.0;
  /// The winner's log-likelihood after each EM iteration (never decreasing).
  std::vector<double> log_likelihood_trace;
  /// Why nothing was found ("3 inliers, need 10"), or empty.
  std::string reason;
};

/// Throws std::invalid_argument when params.validate() reports errors.
AlignmentResult estimateFrameTransform(const std::vector<AlignmentCandidate>& candidates,
                                       const AlignmentParams& params);

/// The transform of an earlier estimate, its inliers counted again among `candidates` (its
/// E-step alone, O(n), no search): found while it still has min_inliers and its margin over the
/// earlier runner-up. For re-checking a known transform between full estimates.
AlignmentResult checkFrameTransform(const std::vector<AlignmentCandidate>& candidates,
                                    const AlignmentParams& params, const AlignmentResult& found);

}  // namespace ccir_mapping::core::alignment
