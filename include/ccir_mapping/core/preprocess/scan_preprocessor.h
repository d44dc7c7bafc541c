// Turns a raw lidar scan into a keyframe cloud: range crop, voxel grid, normals, the
// degenerate-normal filter and the optional 2D slice (thesis sections 2.2 and 4.1).
#pragma once

#include <cstddef>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Core>

#include "ccir_mapping/core/preprocess/preprocessor_params.h"

namespace ccir_mapping::core::preprocess {

/// Where the points of one scan went.
struct PreprocessStats {
  std::size_t points_in = 0;
  /// Non-finite coordinates, or the driver's zero point for "no return".
  std::size_t not_finite = 0;
  std::size_t out_of_range = 0;
  std::size_t voxels = 0;
  std::size_t without_normal = 0;
  std::size_t horizontal = 0;
  std::size_t outside_slice = 0;
  std::size_t points_out = 0;
};

class ScanPreprocessor {
 public:
  using InputCloud = pcl::PointCloud<pcl::PointXYZI>;
  using OutputCloud = pcl::PointCloud<pcl::PointXYZINormal>;

  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit ScanPreprocessor(const PreprocessorParams& params);

  /// `scan` is in the sensor frame, any layout (organised or not, NaN or zero for no return);
  /// `up` is the unit up direction (against gravity) in that frame. Returns points with unit
  /// normals pointing towards the sensor; never a non-finite value.
  OutputCloud::Ptr process(const InputCloud& scan, const Eigen::Vector3f& up,
                           PreprocessStats* stats = nullptr) const;

  /// Counts the points process() would keep through the range crop (not_finite, out_of_range
  /// and points_in are filled in `stats`); cheap enough for every scan.
  std::size_t usablePoints(const InputCloud& scan, PreprocessStats* stats = nullptr) const;

  const PreprocessorParams& params() const { return params_; }

 private:
  PreprocessorParams params_;
};

}  // namespace ccir_mapping::core::preprocess
