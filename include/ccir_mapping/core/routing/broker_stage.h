// The Broker's stage: CCIR (CcirBroker) with what it needs around it, in one shape for every
// input: each step takes plain data and returns an Output, everything the caller must send and
// every refusal to report. Own keyframes get their footprint on an empty map of the Mapper's
// parameters, and their wire form is kept for as long as CCIR keeps them, to be sent on request;
// offered scans are scored against this robot's map (SharedMap).
// `Scan` is whatever holds a wire form: the nodelet keeps its message pointers (sent again
// without a copy), a ROS-free runner its encoded bytes.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/shared_map.h"
#include "ccir_mapping/core/routing/ccir_broker.h"

namespace ccir_mapping::core::routing {

template <class Scan>
class BrokerStage {
 public:
  /// What one step asks the caller to send, and what it refused.
  struct Output {
    std::vector<Offer> offers;      // each to its requester
    std::vector<Request> requests;  // each to its provider
    std::vector<Receipt> receipts;  // each to its provider
    /// Wire forms, each for one teammate or ("") for every teammate.
    std::vector<std::pair<std::string, Scan>> scans;
    /// What teammates sent that was refused or dropped.
    std::vector<Notice> refused;
  };

  /// Throws std::invalid_argument when either Params is invalid, a peer is this robot or a
  /// peer is named twice.
  BrokerStage(std::string self, std::vector<std::string> peers, const BrokerParams& params,
              const information::MapperParams& map_params)
      : self_(self), ccir_(std::move(self), std::move(peers), params), footprint_map_(map_params) {}

  /// The state CCIR weighs with (links, transforms, poses, c_k, uncertainty) goes straight in.
  CcirBroker& ccir() { return ccir_; }
  const CcirBroker& ccir() const { return ccir_; }

  /// An own keyframe: its points (sensor frame), odometry pose and wire form of `size_bytes`;
  /// in fixed_rate and all it may go to every teammate now.
  Output addKeyframe(KeyframeId id, Stamp stamp, const Pose3& odom_pose,
                     const pcl::PointCloud<pcl::PointXYZ>& points, Scan scan,
                     std::size_t size_bytes) {
    auto footprint = CcirBroker::footprint(footprint_map_, points, ccir_.placeOwn(odom_pose));
    for (const KeyframeId evicted :
         ccir_.addKeyframe(id, stamp, odom_pose, size_bytes, std::move(footprint))) {
      kept_.erase(evicted);
    }
    kept_[id] = scan;
    Output out;
    if (ccir_.sendsToAll(id)) out.scans.emplace_back("", std::move(scan));
    return out;
  }

  /// One offer period: offers, requests for the offers received (scored with the CSQMI of this
  /// robot's map, shared in this process by its Mapper; 0 while there is none), receipts.
  Output runPeriod(double now_s) {
    const auto map = information::SharedMap::find(self_);
    auto period = ccir_.runPeriod(
        [&](const Pose3& pose) {
          return map ? map->read([&](const auto& m) { return m.simulatedCsqmi(pose); }) : 0.0;
        },
        now_s);
    Output out;
    out.offers = std::move(period.offers);
    out.requests = std::move(period.requests);
    out.receipts = std::move(period.receipts);
    return out;
  }

  /// A teammate's offer, or why its message could not be read (`malformed`).
  Output onOffer(const Offer& offer, const std::optional<std::string>& malformed = {}) {
    std::string reason = malformed.value_or("");
    if (malformed) {
      ccir_.countRefusal(offer.provider, "malformed_offer");
    } else if (ccir_.onOffer(offer, &reason)) {
      return {};
    }
    return refused("offer " + reason, "refusing an offer from '" + offer.provider + "': " + reason);
  }

  /// A teammate's request: the kept wire forms it may have.
  Output onRequest(const Request& request, double now_s) {
    const auto outcome = ccir_.onRequest(request, now_s);
    Output out;
    for (const auto& [reason, n] : outcome.refused) {
      out.refused.push_back({"request " + reason, "refusing " + std::to_string(n) + " scan(s) " +
                                                      request.requester + " asked for: " + reason});
    }
    for (const KeyframeId id : outcome.send) {
      out.scans.emplace_back(request.requester, kept_.at(id));
    }
    return out;
  }

  Output onReceipt(const Receipt& receipt) {
    if (ccir_.onReceipt(receipt)) return {};
    return refused("receipt", "refusing a receipt from '" + receipt.receiver + "' for '" +
                                  receipt.provider + "'");
  }

  /// A teammate's scan of `size_bytes`, or why it could not be decoded (`undecodable`): it is
  /// used (no refusal) unless undecodable, received before or not a teammate's.
  Output onScan(const std::string& provider, KeyframeId id, std::size_t size_bytes,
                const std::optional<std::string>& undecodable = {}) {
    const std::string what = "dropping scan " + std::to_string(id) + " of '" + provider + "': ";
    if (undecodable) {
      ccir_.countRefusal(provider, "undecodable_scan");
      return refused("undecodable scan", what + *undecodable);
    }
    if (ccir_.onScanReceived(provider, id, size_bytes)) return {};
    return refused("scan", what + "received before, or not a teammate's");
  }

  std::size_t keptScans() const { return kept_.size(); }

 private:
  static Output refused(std::string kind, std::string text) {
    Output out;
    out.refused.push_back({std::move(kind), std::move(text)});
    return out;
  }

  std::string self_;
  CcirBroker ccir_;
  information::OccupancyMap footprint_map_;
  std::map<KeyframeId, Scan> kept_;
};

}  // namespace ccir_mapping::core::routing
