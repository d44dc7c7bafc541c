#include "ccir_mapping/core/preprocess/lidar_odometry_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::preprocess {

std::vector<std::string> LidarOdometryParams::validate() const {
  ParamCheck check;
  check.inRange("lidar_voxel_m", voxel_m, 0.05, 5.0);
  check.inRange("lidar_min_range_m", min_range_m, 0.0, 50.0);
  check.inRange("lidar_local_map_scans", local_map_scans, 1, 1000);
  check.inRange("lidar_local_map_step_m", local_map_step_m, 0.0, 100.0);
  check.inRange("lidar_local_map_step_deg", local_map_step_deg, 0.0, 180.0);
  check.inHalfOpenRange("lidar_max_correspondence_m", max_correspondence_m, 0.0, 100.0);
  check.inRange("lidar_max_iterations", max_iterations, 1, 1000);
  check.inHalfOpenRange("lidar_max_fitness_m2", max_fitness_m2, 0.0, 100.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::preprocess
