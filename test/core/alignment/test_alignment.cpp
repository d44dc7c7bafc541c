// The EM estimator of the transform between two robots' frames (algorithms.md section 4.5):
// accuracy with many false candidates, a smaller consistent false group loses, nothing found
// without inliers, monotone likelihood, and pose uncertainty keeping drifted true loops.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/testing/synthetic_candidates.h"

namespace ccir_mapping::core::alignment {
namespace {

using testing::makeSyntheticCandidates;
using testing::SyntheticCandidates;
using testing::SyntheticSpec;

struct Error {
  double translation_m;
  double rotation_deg;
};

Error errorOf(const AlignmentResult& result, const Pose3& truth) {
  const Pose3 d = truth.inverse() * result.transform;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle() * 180.0 / M_PI};
}

TEST(FrameAlignment, FindsTheTransformAmongManyFalseCandidates) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SyntheticSpec spec;
    spec.seed = seed;
    const SyntheticCandidates s = makeSyntheticCandidates(spec);  // 20 inliers, 60 outliers
    const AlignmentResult result = estimateFrameTransform(s.candidates, AlignmentParams{});
    ASSERT_TRUE(result.found) << "seed " << seed << ": " << result.reason;
    const Error e = errorOf(result, s.truth);
    EXPECT_LT(e.translation_m, 0.1) << seed;
    EXPECT_LT(e.rotation_deg, 1.0) << seed;
    int true_positive = 0;
    int positive = 0;
    for (std::size_t k = 0; k < s.inlier.size(); ++k) {
      positive += result.inliers[k];
      true_positive += result.inliers[k] && s.inlier[k];
    }
    EXPECT_GE(double(true_positive) / positive, 0.95) << seed;
    EXPECT_GE(true_positive / 20.0, 0.9) << seed;
    // The log-likelihood never decreases.
    for (std::size_t i = 1; i < result.log_likelihood_trace.size(); ++i) {
      EXPECT_GE(result.log_likelihood_trace[i], result.log_likelihood_trace[i - 1] - 1e-6);
    }
  }
}

TEST(FrameAlignment, NinetyEightPercentOutliers) {
  SyntheticSpec spec;
  spec.inliers = 10;
  spec.outliers = 490;
  spec.seed = 7;
  const SyntheticCandidates s = makeSyntheticCandidates(spec);
  const AlignmentResult result = estimateFrameTransform(s.candidates, AlignmentParams{});
  ASSERT_TRUE(result.found) << result.reason;
  const Error e = errorOf(result, s.truth);
  EXPECT_LT(e.translation_m, 0.1);
  EXPECT_LT(e.rotation_deg, 1.0);
}

TEST(FrameAlignment, SmallerConsistentFalseGroupLoses) {
  SyntheticSpec spec;
  spec.aliased = 8;
  spec.outliers = 30;
  spec.seed = 3;
  const SyntheticCandidates s = makeSyntheticCandidates(spec);
  const AlignmentResult result = estimateFrameTransform(s.candidates, AlignmentParams{});
  ASSERT_TRUE(result.found) << result.reason;
  EXPECT_LT(errorOf(result, s.truth).translation_m, 0.1);
  EXPECT_GE(result.runner_up_inliers, 6);  // the aliased group was seen, and lost
}

TEST(FrameAlignment, ACheckOfAKnownTransformCountsItsInliersAgainWithoutSearching) {
  SyntheticSpec spec;
  spec.seed = 2;
  const SyntheticCandidates s = makeSyntheticCandidates(spec);  // 20 inliers, 60 outliers
  const AlignmentResult found = estimateFrameTransform(s.candidates, AlignmentParams{});
  ASSERT_TRUE(found.found) << found.reason;
  const AlignmentResult same = checkFrameTransform(s.candidates, AlignmentParams{}, found);
  EXPECT_TRUE(same.found);
  EXPECT_EQ(same.inlier_count, found.inlier_count);
  EXPECT_TRUE(same.transform.isApprox(found.transform));
  // Only the false candidates and 5 true ones left: the transform no longer holds.
  std::vector<AlignmentCandidate> fewer;
  int kept_true = 0;
  for (std::size_t k = 0; k < s.candidates.size(); ++k) {
    if (s.inlier[k] && kept_true++ >= 5) continue;
    fewer.push_back(s.candidates[k]);
  }
  const AlignmentResult weak = checkFrameTransform(fewer, AlignmentParams{}, found);
  EXPECT_FALSE(weak.found);
  EXPECT_LE(weak.inlier_count, 6);
  EXPECT_NE(weak.reason.find("inliers of the transform found before"), std::string::npos);
}

TEST(FrameAlignment, NoInliersNoTransform) {
  SyntheticSpec aliased_only;
  aliased_only.inliers = 0;
  aliased_only.aliased = 8;
  aliased_only.outliers = 0;
  const AlignmentResult alias =
      estimateFrameTransform(makeSyntheticCandidates(aliased_only).candidates, AlignmentParams{});
  EXPECT_FALSE(alias.found);
  EXPECT_NE(alias.reason.find("need 10"), std::string::npos) << alias.reason;

  SyntheticSpec random_only;
  random_only.inliers = 0;
  random_only.outliers = 100;
  EXPECT_FALSE(
      estimateFrameTransform(makeSyntheticCandidates(random_only).candidates, AlignmentParams{})
          .found);
  EXPECT_FALSE(estimateFrameTransform({}, AlignmentParams{}).found);
}

TEST(FrameAlignment, PoseUncertaintyKeepsTrueLoopsSeenAfterDrift) {
  SyntheticSpec spec;
  spec.inliers = 30;
  spec.outliers = 30;
  spec.drift_per_keyframe_m = 0.2;
  spec.seed = 11;
  const SyntheticCandidates s = makeSyntheticCandidates(spec);
  auto recall = [&](bool uncertainty) {
    AlignmentParams params;
    params.use_pose_uncertainty = uncertainty;
    const AlignmentResult result = estimateFrameTransform(s.candidates, params);
    int kept = 0;
    for (std::size_t k = 0; k < s.inlier.size(); ++k) kept += result.inliers[k] && s.inlier[k];
    return kept / 30.0;
  };
  const double with = recall(true);
  const double without = recall(false);
  EXPECT_GT(with, without + 0.2) << "with " << with << ", without " << without;
  EXPECT_GT(with, 0.8);
}

TEST(FrameAlignment, InvalidParametersAndCovariances) {
  AlignmentParams bad;
  bad.inlier_prior = 1.5;
  EXPECT_THROW(estimateFrameTransform({}, bad), std::invalid_argument);
  SyntheticSpec spec;
  SyntheticCandidates s = makeSyntheticCandidates(spec);
  s.candidates[0].covariance = -Matrix6::Identity();
  EXPECT_THROW(estimateFrameTransform(s.candidates, AlignmentParams{}), std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::alignment
