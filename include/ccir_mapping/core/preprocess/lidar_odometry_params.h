// Parameters of the lidar odometry (lidar_odometry.h): for bags and robots without odometry.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::preprocess {

struct LidarOdometryParams {
  /// Voxel edge of the scans and the local map registered: ~3 k points of a VLP-16 scan in a
  /// drift, which GICP aligns in ~20 ms.
  double voxel_m = 0.3;
  /// Points closer than this to the sensor are left out (the robot's body moves with it).
  double min_range_m = 1.0;
  /// Registered scans that make up the local map each new scan is aligned to.
  int local_map_scans = 20;
  /// A registered scan joins the local map after this much travel since the last one joined ...
  double local_map_step_m = 0.5;
  /// ... or this much rotation.
  double local_map_step_deg = 10.0;
  /// GICP pairs points at most this far apart (after the motion prediction).
  double max_correspondence_m = 1.0;
  int max_iterations = 30;
  /// A registration with a larger mean squared distance of its pairs is refused: the scan is
  /// placed by the motion prediction alone and does not join the local map.
  double max_fitness_m2 = 0.25;

  /// Empty when valid; otherwise one message per invalid parameter, named as the YAML key
  /// (`lidar_` + field).
  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::preprocess
