// The long-term store of a robot's HGMM map (thesis section 6.2): a scan becomes a new HGMM
// keyframe only where the mixtures already stored do not explain it - when too small a share of
// its points lies within the chi-square gate of a stored Gaussian. What is kept per keyframe is
// one level of its hierarchy, in the map frame, so memory grows with new ground, not with time.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/hgmm/hgmm.h"

namespace ccir_mapping::core::hgmm {

struct NoveltyParams {
  HgmmParams hgmm;
  /// The level stored for a keyframe (the deepest present when the hierarchy stops earlier).
  int stored_level = 2;
  /// A point is explained when a stored Gaussian has it within this squared Mahalanobis
  /// distance (11.34: the 99 % chi-square quantile in 3D).
  double explained_mahalanobis2 = 11.34;
  /// A scan whose explained share is below this becomes a keyframe.
  double min_explained_share = 0.7;
  /// Points tested per scan (a seeded subset; the share needs no more).
  int test_points = 500;

  std::vector<std::string> validate() const;
};

class NoveltyKeyframes {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit NoveltyKeyframes(const NoveltyParams& params);

  /// Share of `points` (sensor frame, the sensor at `pose` in the map) that the stored
  /// mixtures explain; 0 while none is stored.
  double explainedShare(const Points& points, const Pose3& pose) const;
  /// Stores the scan's HGMM level when it is novel; returns whether it did.
  bool offer(const Points& points, const Pose3& pose);

  const std::vector<GaussianMixture>& keyframes() const { return keyframes_; }
  /// Wire bytes of everything stored.
  std::size_t bytes() const { return bytes_; }

 private:
  NoveltyParams params_;
  std::vector<GaussianMixture> keyframes_;  // in the map frame
  /// Lower Cholesky factors of every stored Gaussian, for the gate.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Matrix3d>> gates_;
  std::size_t bytes_ = 0;
};

}  // namespace ccir_mapping::core::hgmm
