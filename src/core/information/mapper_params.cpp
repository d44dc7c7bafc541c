#include "ccir_mapping/core/information/mapper_params.h"

#include <cmath>
#include <string>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::information {

std::vector<std::string> MapperParams::validate() const {
  ParamCheck check;
  check.inRange("resolution_m", resolution_m, 0.01, 2.0);
  check.inHalfOpenRange("max_insert_range_m", max_insert_range_m, 0.0, 300.0);
  check.inRange("occupancy_clamp_min", occupancy_clamp_min, 0.0001, 0.49);
  check.inRange("occupancy_clamp_max", occupancy_clamp_max, 0.51, 0.9999);
  check.inHalfOpenRange("csqmi_sigma_m", csqmi_sigma_m, 0.0, 10.0);
  check.inHalfOpenRange("simulated_azimuth_step_deg", simulated_azimuth_step_deg, 0.0, 90.0);
  check.inRange("scan_beam_step", scan_beam_step, 1, 100000);
  check.inRange("submap_scans", submap_scans, 1, 10000);
  check.inHalfOpenRange("reanchor_shift_m", reanchor_shift_m, 0.0, 100.0);
  check.inHalfOpenRange("reanchor_rotation_deg", reanchor_rotation_deg, 0.0, 180.0);
  check.inRange("reanchor_wait_s_per_mvoxel_visited", reanchor_wait_s_per_mvoxel_visited, 0.0,
                1000.0);
  check.inRange("submap_window_scans", submap_window_scans, 0, 1000000);
  check.inHalfOpenRange("entropy_box_half_width_m", entropy_box_half_width_m, 0.0, 10000.0);
  check.inRange("entropy_box_min_z_m", entropy_box_min_z_m, -1000.0, 1000.0);
  check.inRange("entropy_box_max_z_m", entropy_box_max_z_m, -1000.0, 1000.0);
  check.require(entropy_box_min_z_m < entropy_box_max_z_m,
                "entropy_box_min_z_m must be below entropy_box_max_z_m");
  // OctoMap addresses +-32768 voxels from the origin; a box beyond would be measured as empty.
  const double reach_m = 32767.0 * resolution_m;
  check.require(entropy_box_half_width_m < reach_m && std::abs(entropy_box_min_z_m) < reach_m &&
                    std::abs(entropy_box_max_z_m) < reach_m,
                "entropy_box_half_width_m, entropy_box_min_z_m and entropy_box_max_z_m must stay "
                "within the map's reach (32767 x resolution_m = " +
                    std::to_string(reach_m) + " m)");
  check.inRange("publish_period_s", publish_period_s, 0.05, 3600.0);
  return check.errors();
}

Eigen::Vector3d MapperParams::entropyBoxMin() const {
  return {-entropy_box_half_width_m, -entropy_box_half_width_m, entropy_box_min_z_m};
}

Eigen::Vector3d MapperParams::entropyBoxMax() const {
  return {entropy_box_half_width_m, entropy_box_half_width_m, entropy_box_max_z_m};
}

}  // namespace ccir_mapping::core::information
