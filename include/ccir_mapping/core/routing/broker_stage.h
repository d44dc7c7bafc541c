// The Broker's stage: CCIR (CcirBroker) with what it needs around it, in one shape for every
// input: each step takes plain data and returns an Output, everything the caller must send and
// every refusal to report. Own keyframes get their footprint on an empty map of the Mapper's
// parameters, and their wire form is kept for as long as CCIR keeps them, to be sent on request;
// offered scans are scored against this robot's map (the Mapper's SharedMap, an explicit input:
// setMap). Control messages are counted at the size the caller's wire gives them.
// `Scan` is whatever holds a wire form: the nodelet keeps its message pointers (sent again
// without a copy), a ROS-free runner its encoded bytes.
#pragma once

#include <functional>
#include <map>
#include <memory>
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

  /// The bytes a control message takes on the wire (each is counted as the Broker's control
  /// bytes to its teammate).
  using ControlBytes = std::function<std::size_t(const ControlMessage&)>;

  /// Throws std::invalid_argument when either Params is invalid, a peer is this robot or a
  /// peer is named twice.
  BrokerStage(std::string self, std::vector<std::string> peers, const BrokerParams& params,
              const information::MapperParams& map_params, ControlBytes control_bytes = {})
      : ccir_(std::move(self), std::move(peers), params),
        footprint_map_(map_params),
        control_bytes_(std::move(control_bytes)) {}

  /// The map requests are scored with (the Mapper's, shared in this process); until it is set,
  /// every offered scan scores 0.
  void setMap(std::shared_ptr<const information::SharedMap> map) { map_ = std::move(map); }
  bool hasMap() const { return map_ != nullptr; }

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

  /// c_k of own keyframes with keyframes of teammate `peer` (the Matcher's).
  void onCorrespondences(const std::string& peer,
                         const std::vector<std::pair<KeyframeId, int>>& counts) {
    for (const auto& [id, c] : counts) ccir_.setCorrespondences(peer, id, c);
  }

  /// One offer period: offers, requests for the offers received (scored with the CSQMI of the
  /// map, setMap), receipts; each counted as control bytes.
  Output runPeriod(double now_s) {
    auto period = ccir_.runPeriod(
        [&](const Pose3& pose) {
          return map_ ? map_->read([&](const auto& m) { return m.simulatedCsqmi(pose); }) : 0.0;
        },
        now_s);
    Output out;
    out.offers = std::move(period.offers);
    out.requests = std::move(period.requests);
    out.receipts = std::move(period.receipts);
    for (const auto& o : out.offers) countControl(o.requester, o);
    for (const auto& r : out.requests) countControl(r.provider, r);
    for (const auto& r : out.receipts) countControl(r.provider, r);
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
  void countControl(const std::string& peer, ControlMessage message) {
    if (control_bytes_) ccir_.addControlBytes(peer, control_bytes_(message));
  }

  static Output refused(std::string kind, std::string text) {
    Output out;
    out.refused.push_back({std::move(kind), std::move(text)});
    return out;
  }

  CcirBroker ccir_;
  information::OccupancyMap footprint_map_;
  ControlBytes control_bytes_;
  std::shared_ptr<const information::SharedMap> map_;
  std::map<KeyframeId, Scan> kept_;
};

}  // namespace ccir_mapping::core::routing
