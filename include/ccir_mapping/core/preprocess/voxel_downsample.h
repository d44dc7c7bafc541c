// Voxel-grid down-sampling that works for any extent of the cloud.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace ccir_mapping::core::preprocess {

/// One point per occupied voxel of edge `leaf_m` (the centroid of every field, as
/// pcl::VoxelGrid computes it). pcl::VoxelGrid indexes voxels with 32-bit integers and returns
/// the cloud unfiltered when the extent needs more; this splits such clouds along x at a voxel
/// boundary first, so the result is the same as one grid over the whole cloud.
template <class PointT>
typename pcl::PointCloud<PointT>::Ptr voxelDownsample(const pcl::PointCloud<PointT>& cloud,
                                                      double leaf_m);

}  // namespace ccir_mapping::core::preprocess
