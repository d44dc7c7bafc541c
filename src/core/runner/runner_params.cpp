#include "ccir_mapping/core/runner/runner_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::runner {

std::optional<Topology> parseTopology(std::string_view text) {
  if (text == "all_pairs") return Topology::kAllPairs;
  if (text == "radio_range") return Topology::kRadioRange;
  return std::nullopt;
}

const char* toString(Topology topology) {
  return topology == Topology::kAllPairs ? "all_pairs" : "radio_range";
}

std::vector<std::string> RunnerParams::validate() const {
  ParamCheck check;
  check.inRange("radio_range_m", radio_range_m, 0.0, 1e6);
  check.inRange("max_peers", max_peers, 0, 100000);
  check.inRange("step_s", step_s, 0.01, 1.0);
  check.inRange("series_period_s", series_period_s, step_s, 3600.0);
  std::vector<std::string> errors = check.errors();
  for (auto more :
       {mission.validate(), preprocessor.validate(), matcher.validate(), backend.validate(),
        mapper.validate(), broker.validate(), bridge.validate("robot_a"), radio.validate()}) {
    errors.insert(errors.end(), more.begin(), more.end());
  }
  return errors;
}

}  // namespace ccir_mapping::core::runner
