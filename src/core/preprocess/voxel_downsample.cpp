#include "ccir_mapping/core/preprocess/voxel_downsample.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include <pcl/common/common.h>
#include <pcl/filters/voxel_grid.h>

namespace ccir_mapping::core::preprocess {
namespace {

template <class PointT>
void downsampleInto(const typename pcl::PointCloud<PointT>::ConstPtr& cloud, double leaf_m,
                    pcl::PointCloud<PointT>* out) {
  if (cloud->empty()) return;
  PointT lo;
  PointT hi;
  pcl::getMinMax3D(*cloud, lo, hi);
  const double cells = (std::floor(hi.x / leaf_m) - std::floor(lo.x / leaf_m) + 1) *
                       (std::floor(hi.y / leaf_m) - std::floor(lo.y / leaf_m) + 1) *
                       (std::floor(hi.z / leaf_m) - std::floor(lo.z / leaf_m) + 1);
  if (cells < 0.5 * std::numeric_limits<std::int32_t>::max() || hi.x - lo.x < 2 * leaf_m) {
    pcl::VoxelGrid<PointT> grid;
    grid.setInputCloud(cloud);
    grid.setLeafSize(leaf_m, leaf_m, leaf_m);
    pcl::PointCloud<PointT> part;
    grid.filter(part);
    *out += part;
    return;
  }
  // Too many cells for one grid: split at a voxel boundary near the middle of x.
  const double split = std::floor(0.5 * (lo.x + hi.x) / leaf_m) * leaf_m;
  auto left = pcl::make_shared<pcl::PointCloud<PointT>>();
  auto right = pcl::make_shared<pcl::PointCloud<PointT>>();
  for (const auto& p : *cloud) (p.x < split ? left : right)->push_back(p);
  downsampleInto<PointT>(left, leaf_m, out);
  downsampleInto<PointT>(right, leaf_m, out);
}

}  // namespace

template <class PointT>
typename pcl::PointCloud<PointT>::Ptr voxelDownsample(const pcl::PointCloud<PointT>& cloud,
                                                      double leaf_m) {
  auto out = pcl::make_shared<pcl::PointCloud<PointT>>();
  out->header = cloud.header;
  // VoxelGrid takes a shared pointer; wrap the caller's cloud without copying it.
  const typename pcl::PointCloud<PointT>::ConstPtr input(&cloud, [](const auto*) {});
  downsampleInto<PointT>(input, leaf_m, out.get());
  out->is_dense = true;
  return out;
}

template pcl::PointCloud<pcl::PointXYZ>::Ptr voxelDownsample(const pcl::PointCloud<pcl::PointXYZ>&,
                                                             double);
template pcl::PointCloud<pcl::PointXYZI>::Ptr voxelDownsample(
    const pcl::PointCloud<pcl::PointXYZI>&, double);
template pcl::PointCloud<pcl::PointXYZINormal>::Ptr voxelDownsample(
    const pcl::PointCloud<pcl::PointXYZINormal>&, double);

}  // namespace ccir_mapping::core::preprocess
