// One rotation of a Velodyne-style lidar in the layout its ROS driver publishes: the simulator
// makes them, the pcap reader decodes them.
#pragma once

#include <cstdint>
#include <vector>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core {

/// One return in the sensor frame at the time of its firing (raw, not motion-compensated), the
/// fields the Velodyne ROS driver publishes.
struct LidarPoint {
  float x, y, z;
  float intensity;
  std::uint16_t ring;
  /// Seconds after the scan's stamp.
  float time;
};

struct LidarScan {
  /// Start of the sweep.
  Stamp stamp = 0;
  /// Organised scans hold rings x columns points (row = ring), NaN where a beam had no return;
  /// others hold only returns, column by column.
  bool organized = false;
  int rings = 16;
  int columns = 0;
  std::vector<LidarPoint> points;
};

}  // namespace ccir_mapping::core
