// Parameters of the distributed occupancy map.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::information {

struct MapperParams {
  /// OctoMap leaf size.
  double resolution_m = 0.1;
  /// Beams are integrated up to this range (longer ones clear free space only up to it).
  double max_insert_range_m = 30.0;
  /// Period of map statistics and visualisation output.
  double publish_period_s = 2.0;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::information
