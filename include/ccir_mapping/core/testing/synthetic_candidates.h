// Synthetic two-robot loop-closure candidates with known truth, for tests and the alignment
// benchmark.
#pragma once

#include <vector>

#include "ccir_mapping/core/alignment/frame_alignment.h"

namespace ccir_mapping::core::testing {

struct SyntheticCandidates {
  Pose3 truth;  // T^a_b
  /// Robot a's keyframe poses and robot b's estimated ones, each in its own frame.
  std::vector<Pose3> poses_a;
  std::vector<Pose3> poses_b;
  std::vector<alignment::AlignmentCandidate> candidates;
  /// Per candidate: the keyframes it joins, and whether it is true.
  std::vector<int> index_a;
  std::vector<int> index_b;
  std::vector<bool> inlier;
};

struct SyntheticSpec {
  /// Keyframes per robot.
  int keyframes = 200;
  int inliers = 20;
  int outliers = 60;
  /// A consistent group of false candidates, generated from another transform.
  int aliased = 0;
  double translation_sigma_m = 0.1;
  double rotation_sigma_deg = 1.0;
  /// Robot b's poses drift: a random walk of this standard deviation per keyframe (0.5 m apart);
  /// the candidates carry matching pose covariances.
  double drift_per_keyframe_m = 0.0;
  unsigned seed = 1;
};

SyntheticCandidates makeSyntheticCandidates(const SyntheticSpec& spec);

}  // namespace ccir_mapping::core::testing
