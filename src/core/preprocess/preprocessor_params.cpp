#include "ccir_mapping/core/preprocess/preprocessor_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::preprocess {

std::vector<std::string> PreprocessorParams::validate() const {
  ParamCheck check;
  check.inRange("min_range_m", min_range_m, 0.0, 50.0);
  check.inHalfOpenRange("max_range_m", max_range_m, 0.0, 300.0);
  check.require(max_range_m > min_range_m, "max_range_m must be greater than min_range_m");
  check.inRange("voxel_leaf_m", voxel_leaf_m, 0.01, 5.0);
  check.inRange("normal_radius_m", normal_radius_m, 0.05, 10.0);
  check.require(normal_radius_m >= 2.0 * voxel_leaf_m,
                "normal_radius_m must be at least 2 * voxel_leaf_m (a normal needs neighbours)");
  check.inRange("horizontal_normal_z", horizontal_normal_z, 0.0, 1.0);
  check.inRange("slice_min_z_m", slice_min_z_m, -50.0, 50.0);
  check.inRange("slice_max_z_m", slice_max_z_m, -50.0, 50.0);
  check.require(slice_max_z_m > slice_min_z_m, "slice_max_z_m must be greater than slice_min_z_m");
  check.inRange("threads", threads, 0, 64);
  check.inRange("min_points", min_points, 1, 10000000);
  check.inRange("max_points", max_points, 1, 100000000);
  check.require(max_points >= min_points, "max_points must be at least min_points");
  check.inRange("keyframe_distance_m", keyframe_distance_m, 0.0, 100.0);
  check.inRange("keyframe_rotation_deg", keyframe_rotation_deg, 0.0, 180.0);
  check.inHalfOpenRange("odom_tolerance_s", odom_tolerance_s, 0.0, 5.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::preprocess
