#include "ccir_mapping/core/routing/broker_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::routing {

std::optional<RoutingMode> parseRoutingMode(std::string_view text) {
  if (text == "ccir") return RoutingMode::kCcir;
  if (text == "fixed_rate") return RoutingMode::kFixedRate;
  return std::nullopt;
}

const char* toString(RoutingMode mode) {
  return mode == RoutingMode::kCcir ? "ccir" : "fixed_rate";
}

std::vector<std::string> BrokerParams::validate() const {
  ParamCheck check;
  check.inRange("loop_closure_weight", loop_closure_weight, 0.0, 1.0);
  check.inHalfOpenRange("unknown_transform_factor", unknown_transform_factor, 0.0, 1.0);
  check.inRange("budget_bytes_per_s", budget_bytes_per_s, 1000.0, 1e9);
  check.inRange("offer_period_s", offer_period_s, 0.05, 600.0);
  check.inRange("fixed_rate_every_n", fixed_rate_every_n, 1, 100000);
  check.inRange("stats_period_s", stats_period_s, 0.05, 3600.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::routing
