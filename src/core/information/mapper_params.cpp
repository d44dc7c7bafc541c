#include "ccir_mapping/core/information/mapper_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::information {

std::vector<std::string> MapperParams::validate() const {
  ParamCheck check;
  check.inRange("resolution_m", resolution_m, 0.01, 2.0);
  check.inHalfOpenRange("max_insert_range_m", max_insert_range_m, 0.0, 300.0);
  check.inRange("publish_period_s", publish_period_s, 0.05, 3600.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::information
