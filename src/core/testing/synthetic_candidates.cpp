#include "ccir_mapping/core/testing/synthetic_candidates.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>

namespace ccir_mapping::core::testing {
namespace {

Pose3 planar(double x, double y, double z, double yaw) {
  Pose3 p = Pose3::Identity();
  p.translation() << x, y, z;
  p.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

}  // namespace

SyntheticCandidates makeSyntheticCandidates(const SyntheticSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  SyntheticCandidates s;
  // Teams start near each other: frames within 10 m.
  s.truth = planar(10 * u(rng), 10 * u(rng), 0.5 * u(rng), M_PI * u(rng));
  const Pose3 alias = planar(10 * u(rng), 10 * u(rng), 0.5 * u(rng), M_PI * u(rng));

  // Robot a wanders in 0.5 m steps near its start; robot b drives the same path, seen in its own
  // frame, within 2 m of a: true loop closures join nearby keyframes. Robot b's estimate may
  // drift.
  std::vector<Pose3> a{planar(5 * u(rng), 5 * u(rng), 0, M_PI * u(rng))};
  for (int k = 1; k < spec.keyframes; ++k) a.push_back(a.back() * planar(0.5, 0, 0, 0.6 * u(rng)));
  std::vector<Pose3> b_true;
  for (const Pose3& pose : a) {
    b_true.push_back(s.truth.inverse() * pose *
                     planar(2 * u(rng), 2 * u(rng), 0.2 * u(rng), 0.5 * u(rng)));
  }
  std::vector<Pose3> b_estimate = b_true;
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();
  for (std::size_t k = 1; k < b_estimate.size(); ++k) {
    drift += spec.drift_per_keyframe_m * Eigen::Vector3d(n(rng), n(rng), 0.0);
    b_estimate[k].translation() += drift;
  }

  const double st = spec.translation_sigma_m;
  const double sr = spec.rotation_sigma_deg * M_PI / 180.0;
  Matrix6 covariance = Matrix6::Zero();
  covariance.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  auto candidate = [&](const Pose3& transform, bool noisy_truth) {
    const int j = std::uniform_int_distribution<int>(0, spec.keyframes - 1)(rng);
    // True and aliased loops join keyframes at the same place; false ones any two.
    const int i = noisy_truth ? j : std::uniform_int_distribution<int>(0, spec.keyframes - 1)(rng);
    s.index_a.push_back(i);
    s.index_b.push_back(j);
    alignment::AlignmentCandidate c;
    c.pose_a = a[static_cast<std::size_t>(i)];
    c.pose_b = b_estimate[static_cast<std::size_t>(j)];
    c.covariance = covariance;
    const double var_b = spec.drift_per_keyframe_m * spec.drift_per_keyframe_m * j;
    c.covariance_b.diagonal() << var_b, var_b, 1e-6, 1e-6, 1e-6, 1e-6;
    if (noisy_truth) {
      // The true relative pose between the true keyframes, measured with noise.
      const Pose3 z = c.pose_a.inverse() * transform * b_true[static_cast<std::size_t>(j)];
      Pose3 noise = planar(st * n(rng), st * n(rng), st * n(rng), sr * n(rng));
      c.measurement = z * noise;
    } else {
      c.measurement = planar(15 * u(rng), 15 * u(rng), 0.5 * u(rng), M_PI * u(rng));
    }
    return c;
  };
  for (int k = 0; k < spec.inliers; ++k) {
    s.candidates.push_back(candidate(s.truth, true));
    s.inlier.push_back(true);
  }
  for (int k = 0; k < spec.aliased; ++k) {
    s.candidates.push_back(candidate(alias, true));
    s.inlier.push_back(false);
  }
  for (int k = 0; k < spec.outliers; ++k) {
    s.candidates.push_back(candidate(Pose3::Identity(), false));
    s.inlier.push_back(false);
  }
  s.poses_a = a;
  s.poses_b = b_estimate;
  return s;
}

}  // namespace ccir_mapping::core::testing
