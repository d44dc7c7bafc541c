#include "ccir_mapping/core/routing/broker_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::routing {

std::optional<RoutingMode> parseRoutingMode(std::string_view text) {
  if (text == "ccir") return RoutingMode::kCcir;
  if (text == "fixed_rate") return RoutingMode::kFixedRate;
  if (text == "all") return RoutingMode::kAll;
  return std::nullopt;
}

const char* toString(RoutingMode mode) {
  switch (mode) {
    case RoutingMode::kCcir:
      return "ccir";
    case RoutingMode::kFixedRate:
      return "fixed_rate";
    case RoutingMode::kAll:
      return "all";
  }
  return "?";
}

std::optional<ScanEncoding> parseScanEncoding(std::string_view text) {
  if (text == "cloud") return ScanEncoding::kCloud;
  if (text == "gmm") return ScanEncoding::kGmm;
  return std::nullopt;
}

const char* toString(ScanEncoding encoding) {
  return encoding == ScanEncoding::kGmm ? "gmm" : "cloud";
}

std::vector<std::string> BrokerParams::validate() const {
  ParamCheck check;
  check.inRange("loop_closure_weight", loop_closure_weight, 0.0, 1.0);
  check.inHalfOpenRange("unknown_transform_factor", unknown_transform_factor, 0.0, 1.0);
  check.inRange("offer_period_s", offer_period_s, 0.05, 600.0);
  check.inRange("max_kept_scans", max_kept_scans, 1, 1000000);
  check.inRange("receipt_timeout_s", receipt_timeout_s, 1.0, 86400.0);
  check.inRange("max_offer_scans", max_offer_scans, 1, 100000);
  check.inRange("min_novelty", min_novelty, 0.0, 1.0);
  check.inRange("fixed_rate_every_n", fixed_rate_every_n, 1, 100000);
  // The root level (8 Gaussians) takes 173 bytes.
  check.inRange("gmm_max_bytes", gmm_max_bytes, 200, 10000000);
  check.inRange("stats_period_s", stats_period_s, 0.05, 3600.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::routing
