#include "ccir_mapping/core/hgmm/hgmm_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::hgmm {

std::vector<std::string> EmParams::validate() const {
  ParamCheck check;
  check.inRange("em_components", components, 1, 1000);
  check.inRange("em_max_iterations", max_iterations, 1, 100000);
  check.inHalfOpenRange("em_tolerance", tolerance, 0.0, 1.0);
  check.inHalfOpenRange("covariance_floor_m2", covariance_floor_m2, 0.0, 100.0);
  check.inRange("em_max_points", max_points, 10, 100000000);
  return check.errors();
}

std::vector<std::string> HgmmParams::validate() const {
  ParamCheck check;
  for (const auto& e : em.validate()) check.require(false, e);
  check.inRange("hgmm_max_depth", max_depth, 0, 10);
  check.inRange("min_points_to_split", min_points_to_split, 2, 100000000);
  return check.errors();
}

}  // namespace ccir_mapping::core::hgmm
