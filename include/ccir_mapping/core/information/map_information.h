// The information questions the CCIR broker asks of a map, whatever represents it (the OctoMap
// now; a Gaussian-mixture map can answer them too).
#pragma once

#include <utility>
#include <vector>

#include <octomap/OcTreeKey.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::information {

/// A voxel and the entropy (bits) an update removes from it.
using VoxelGain = std::pair<octomap::OcTreeKey, float>;

class MapInformation {
 public:
  virtual ~MapInformation() = default;
  /// The voxels whose entropy a scan (sensor frame, at its pose in the map frame) would lower
  /// in this map, with the drop; the map is not changed.
  virtual std::vector<VoxelGain> scanGains(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                           const Pose3& map_from_sensor) const = 0;
  /// What a scan tells a map that knows nothing of its region: the same voxels' entropy drop
  /// from unknown, over a subsample of its beams (the Mapper's scan_beam_step), cheap enough to
  /// compute for every keyframe.
  virtual std::vector<VoxelGain> scanFootprint(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                               const Pose3& map_from_sensor) const = 0;
  /// Mutual information (CSQMI, nats) of a simulated sensor at `sensor_pose` (map frame).
  virtual double simulatedCsqmi(const Pose3& sensor_pose) const = 0;
};

}  // namespace ccir_mapping::core::information
