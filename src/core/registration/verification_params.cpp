#include "ccir_mapping/core/registration/verification_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::registration {

std::vector<std::string> VerificationParams::validate() const {
  ParamCheck check;
  check.inRange("match_neighbors", match_neighbors, 1, 100);
  check.inHalfOpenRange("ransac_inlier_m", ransac_inlier_m, 0.0, 100.0);
  check.inRange("ransac_iterations", ransac_iterations, 1, 1000000);
  check.inRange("min_inliers", min_inliers, 3, 100000);
  check.inHalfOpenRange("gicp_voxel_m", gicp_voxel_m, 0.0, 10.0);
  check.inHalfOpenRange("gicp_max_range_m", gicp_max_range_m, 0.0, 300.0);
  check.inHalfOpenRange("gicp_max_correspondence_m", gicp_max_correspondence_m, 0.0, 100.0);
  check.inRange("gicp_iterations", gicp_iterations, 1, 10000);
  check.inRange("gicp_source_step", gicp_source_step, 1, 100);
  check.inHalfOpenRange("max_fitness_m2", max_fitness_m2, 0.0, 100.0);
  check.inRange("min_overlap", min_overlap, 0.0, 1.0);
  check.inHalfOpenRange("overlap_distance_m", overlap_distance_m, 0.0, 10.0);
  check.inHalfOpenRange("overlap_range_m", overlap_range_m, 0.0, 300.0);
  check.inRange("max_free_space_violation", max_free_space_violation, 0.0, 1.0);
  check.inHalfOpenRange("free_space_margin_m", free_space_margin_m, 0.0, 10.0);
  check.inHalfOpenRange("mixture_overlap_distance_m", mixture_overlap_distance_m, 0.0, 10.0);
  check.inHalfOpenRange("mixture_free_space_margin_m", mixture_free_space_margin_m, 0.0, 10.0);
  check.inHalfOpenRange("range_image_resolution_deg", range_image_resolution_deg, 0.0, 10.0);
  check.inRange("wall_normal_z", wall_normal_z, 0.0, 1.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::registration
