#include "ccir_mapping/core/features/feature_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::features {

std::optional<SpinAxis> parseSpinAxis(std::string_view text) {
  if (text == "z_up") return SpinAxis::kZUp;
  if (text == "normal") return SpinAxis::kNormal;
  return std::nullopt;
}

const char* toString(SpinAxis axis) { return axis == SpinAxis::kZUp ? "z_up" : "normal"; }

std::vector<std::string> FeatureParams::validate() const {
  ParamCheck check;
  check.inHalfOpenRange("max_range_m", max_range_m, 0.0, 300.0);
  check.inRange("horizontal_normal_z", horizontal_normal_z, 0.0, 1.0);
  check.inRange("voxel_m", voxel_m, 0.0, 5.0);
  check.inRange("normal_radius_m", normal_radius_m, 0.05, 10.0);
  check.inHalfOpenRange("iss_salient_radius_m", iss_salient_radius_m, 0.0, 20.0);
  check.inHalfOpenRange("iss_non_max_radius_m", iss_non_max_radius_m, 0.0, 20.0);
  check.inHalfOpenRange("iss_gamma_21", iss_gamma_21, 0.0, 1.0);
  check.inHalfOpenRange("iss_gamma_32", iss_gamma_32, 0.0, 1.0);
  check.inRange("iss_min_neighbors", iss_min_neighbors, 1, 10000);
  check.inHalfOpenRange("spin_support_m", spin_support_m, 0.0, 20.0);
  check.inRange("spin_min_neighbors", spin_min_neighbors, 1, 100000);
  return check.errors();
}

}  // namespace ccir_mapping::core::features
