// Parameters of the CCIR broker that decides which scans are offered, requested and sent.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ccir_mapping::core::routing {

/// CCIR offer/request routing; the thesis baseline that sends every n-th keyframe; or every
/// keyframe (the upper bound on what sharing can give).
enum class RoutingMode { kCcir, kFixedRate, kAll };
constexpr std::string_view kRoutingModeChoices = "ccir | fixed_rate | all";
std::optional<RoutingMode> parseRoutingMode(std::string_view text);
const char* toString(RoutingMode mode);

/// How a shared keyframe crosses the link: its points (transport/scan_codec.h) or a Gaussian
/// mixture of them that the teammate samples (hgmm/scan_mixture.h).
enum class ScanEncoding { kCloud, kGmm };
constexpr std::string_view kScanEncodingChoices = "cloud | gmm";
std::optional<ScanEncoding> parseScanEncoding(std::string_view text);
const char* toString(ScanEncoding encoding);

struct BrokerParams {
  RoutingMode mode = RoutingMode::kCcir;
  /// lambda in U = lambda * F + (1 - lambda) * I: weight of loop-closure potential against map
  /// information.
  double loop_closure_weight = 0.5;
  /// k: factor on map information while the transform to a peer is unknown.
  double unknown_transform_factor = 0.1;
  /// Offers are made, and received offers answered, at this period. Offers and requests are
  /// sized from the bridge's budgets and queues (LinkStats): there is no budget of its own.
  double offer_period_s = 1.0;
  /// Own keyframes kept for teammates to request (in their wire form, ~50-100 KB each); the
  /// oldest go first, and a request for one of them is refused ("evicted").
  int max_kept_scans = 1000;
  /// A scan sent and not acknowledged for this long is taken as lost: it may be offered again.
  double receipt_timeout_s = 60.0;
  /// Most scans an offer from a teammate may hold (a longer one is refused).
  int max_offer_scans = 100;
  /// A keyframe is offered only while at least this share of its footprint's information is
  /// new to the teammate (thesis §3.3.1's thresholding on scan information): the scans of a
  /// place the teammate holds stay home. 0 offers everything the link carries.
  double min_novelty = 0.25;
  /// fixed_rate mode: send every n-th keyframe.
  int fixed_rate_every_n = 5;
  ScanEncoding scan_encoding = ScanEncoding::kCloud;
  /// gmm: the deepest level of the scan's HGMM within this many bytes is sent.
  int gmm_max_bytes = 8000;
  /// Period of BrokerStats.
  double stats_period_s = 1.0;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::routing
