// A lidar rotation (the simulator's or the pcap reader's) as the PCL cloud the Preprocessor's
// core takes, as the ROS path converts the driver's PointCloud2.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/lidar_scan.h"

namespace ccir_mapping::core::preprocess {

/// x y z intensity of every point; an organised scan keeps its rings x columns layout.
pcl::PointCloud<pcl::PointXYZI> toCloud(const LidarScan& scan);

}  // namespace ccir_mapping::core::preprocess
