// What CCIR's offer, request and receipt carry (thesis section 3.2, steps 4-6), and the link state
// and counters the broker keeps per teammate; plain data, converted from and to the ROS messages
// in src/ros/conversions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/routing/broker_params.h"

namespace ccir_mapping::core::routing {

struct OfferEntry {
  KeyframeId id = 0;
  /// The keyframe's sensor pose in the provider's map frame.
  Pose3 pose = Pose3::Identity();
  /// c_k with the requester's keyframes (0: none returned).
  int correspondences = 0;
  std::size_t size_bytes = 0;
  /// U on the provider's ranking.
  double utility = 0.0;
};

struct Offer {
  std::string provider;
  std::string requester;
  std::uint32_t sequence = 0;
  std::vector<OfferEntry> scans;
};

struct Request {
  std::string requester;
  std::string provider;
  std::uint32_t offer_sequence = 0;
  std::vector<KeyframeId> ids;
};

struct Receipt {
  std::string receiver;
  std::string provider;
  std::vector<KeyframeId> ids;
};

/// What CCIR's control traffic carries: everything but the scans.
using ControlMessage = std::variant<Offer, Request, Receipt>;

/// One bridge link as its LinkStats reports it.
struct LinkState {
  bool connected = false;
  double budget_bytes_per_s = 0.0;
  double total_budget_bytes_per_s = 0.0;
  std::size_t queued_control_bytes = 0;
  std::size_t queued_bulk_bytes = 0;
  /// Bytes the link's token buckets let leave at once (at most its burst).
  double available_tokens_bytes = 0.0;
};

/// What the broker did with one teammate since start.
struct PeerCounters {
  std::uint64_t offers_sent = 0, scans_offered = 0;
  std::uint64_t offers_received = 0, scans_in_offers_received = 0;
  std::uint64_t requests_sent = 0, scans_requested = 0;
  std::uint64_t requests_received = 0, scans_requested_by_peer = 0;
  std::uint64_t scans_sent = 0, scan_bytes_sent = 0;
  std::uint64_t scans_received = 0, scan_bytes_received = 0;
  std::uint64_t receipts_sent = 0, receipts_received = 0;
  std::uint64_t control_bytes_sent = 0;
  /// Messages or ids refused, and scans given up, by reason.
  std::map<std::string, std::uint64_t> refused;
};

/// What the broker did since start, over all teammates and per teammate.
struct BrokerReport {
  std::string robot;
  RoutingMode mode = RoutingMode::kCcir;
  /// Own keyframes seen, word sets sent, own scans kept for requests.
  std::uint64_t keyframes = 0, features_sent = 0;
  std::size_t kept_scans = 0;
  /// Scan messages sent (one to all teammates counts once) and received.
  std::uint64_t scans_sent = 0, scans_received = 0;
  std::map<std::string, PeerCounters> peers;
};

}  // namespace ccir_mapping::core::routing
