// ISS keypoints and spin images of a keyframe cloud (PCL ISSKeypoint3D, SpinImageEstimation).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Core>

#include "ccir_mapping/core/features/feature_params.h"
#include "ccir_mapping/core/features/local_features.h"

namespace ccir_mapping::core::features {

struct ExtractionStats {
  std::size_t points = 0;       // after range crop and voxel grid
  std::size_t keypoints = 0;    // ISS
  std::size_t sparse = 0;       // keypoints with too few neighbours for a spin image
  std::size_t degenerate = 0;   // descriptors dropped as non-finite or empty
  std::size_t descriptors = 0;  // returned
};

class FeatureExtractor {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit FeatureExtractor(const FeatureParams& params);

  /// `cloud` is a keyframe cloud (sensor frame, unit normals); `up` the unit up direction in its
  /// frame. Deterministic: PCL's ISS runs on one thread (its multi-threaded path reads stale
  /// scratch values). Never returns a non-finite descriptor.
  LocalFeatures extract(const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                        const Eigen::Vector3f& up, ExtractionStats* stats = nullptr) const;

  /// Spin images of the points `at` (indices into `surface`, whose normals must be unit), turned
  /// around `up` or each point's normal (params().spin_axis). An image that comes out
  /// non-finite or empty (no neighbour inside its cylinder) is nullopt.
  std::vector<std::optional<SpinImage>> describe(
      const pcl::PointCloud<pcl::PointXYZINormal>::ConstPtr& surface, const pcl::Indices& at,
      const Eigen::Vector3f& up) const;

  const FeatureParams& params() const { return params_; }

 private:
  FeatureParams params_;
};

}  // namespace ccir_mapping::core::features
