// Parameters of the CCIR broker that decides which scans are offered, requested and sent.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ccir_mapping::core::routing {

/// CCIR offer/request routing, or the thesis baseline that sends every n-th keyframe.
enum class RoutingMode { kCcir, kFixedRate };
constexpr std::string_view kRoutingModeChoices = "ccir | fixed_rate";
std::optional<RoutingMode> parseRoutingMode(std::string_view text);
const char* toString(RoutingMode mode);

struct BrokerParams {
  RoutingMode mode = RoutingMode::kCcir;
  /// lambda in U = lambda * F + (1 - lambda) * I: weight of loop-closure potential against map
  /// information.
  double loop_closure_weight = 0.5;
  /// k: factor on map information while the transform to a peer is unknown.
  double unknown_transform_factor = 0.1;
  /// Bytes per second this robot may send to each peer; sizes the offers (N).
  double budget_bytes_per_s = 150000.0;
  /// Offers are made, and received offers answered, at this period.
  double offer_period_s = 1.0;
  /// fixed_rate mode: send every n-th keyframe.
  int fixed_rate_every_n = 5;
  /// Period of BrokerStats.
  double stats_period_s = 1.0;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::routing
