#include "ccir_mapping/core/preprocess/lidar_scan_cloud.h"

namespace ccir_mapping::core::preprocess {

pcl::PointCloud<pcl::PointXYZI> toCloud(const LidarScan& scan) {
  pcl::PointCloud<pcl::PointXYZI> cloud;
  cloud.reserve(scan.points.size());
  for (const auto& p : scan.points) {
    pcl::PointXYZI q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.intensity = p.intensity;
    cloud.push_back(q);
  }
  if (scan.organized) {
    cloud.width = static_cast<std::uint32_t>(scan.columns);
    cloud.height = static_cast<std::uint32_t>(scan.rings);
  }
  cloud.is_dense = !scan.organized;
  return cloud;
}

}  // namespace ccir_mapping::core::preprocess
