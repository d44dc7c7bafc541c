// What the occupancy map tests share: a lidar in a box room, small-map parameters and planar
// poses.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Geometry>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/mapper_params.h"

namespace ccir_mapping::core::information {

/// Returns of a ring lidar at `origin` inside the box room [-5, 5] x [-4, 4] x [-1, 2] (its
/// walls, floor and ceiling), 16 rings, one beam per degree.
inline pcl::PointCloud<pcl::PointXYZ> roomScan(const Eigen::Vector3d& origin) {
  const Eigen::Vector3d lo(-5, -4, -1);
  const Eigen::Vector3d hi(5, 4, 2);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (int ring = 0; ring < 16; ++ring) {
    const double elevation = (-15.0 + 2.0 * ring) * M_PI / 180;
    for (int a = 0; a < 360; ++a) {
      const double azimuth = a * M_PI / 180;
      const Eigen::Vector3d d(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      double t = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (d[k] > 1e-9) t = std::min(t, (hi[k] - origin[k]) / d[k]);
        if (d[k] < -1e-9) t = std::min(t, (lo[k] - origin[k]) / d[k]);
      }
      const Eigen::Vector3d p = origin + t * d;
      cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  return cloud;
}

/// 0.2 m voxels, beams up to 20 m: small maps, quick tests.
inline MapperParams params() {
  MapperParams p;
  p.resolution_m = 0.2;
  p.max_insert_range_m = 20.0;
  return p;
}

/// x, y in the plane, turned by yaw_deg about z.
inline Pose3 at(double x, double y, double yaw_deg = 0) {
  return Eigen::Translation3d(x, y, 0) *
         Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ());
}

}  // namespace ccir_mapping::core::information
