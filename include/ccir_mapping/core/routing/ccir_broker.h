// CCIR (thesis section 3.2): which of its keyframes a robot offers each teammate, which offered
// scans it requests, what it sends and what it acknowledges. Every robot plays both roles:
//
// Provider, per teammate i: a belief of what i holds (scans sent to it, and those it
// acknowledged) as the Coverage of their footprints; each period an offer of at most
// N = link capacity / average scan size of its kept keyframes, ranked greedily by
// U = lambda F + (1 - lambda) I (Eq. 3.4), where F = c_k u_k / eta (c_k: shared words with i's
// keyframes, u_k: the keyframe's pose uncertainty, both normalised by their largest product
// eta; u_k counts as equal for all while the transform to i is unknown, since before that every
// keyframe could be the one that finds it) and I = the entropy the scan's footprint adds to the
// belief, normalised by the largest, times unknown_transform_factor while the transform is
// unknown. Each pick enters the belief before the next (ScanRanker), so two scans of one place
// are not both offered for their map information; a scan of which less than min_novelty would be
// new to i (at its pick) is not offered at all. Scans i holds are never offered.
//
// Requester: the offers of a period, scored by S = lambda c_k / c_max + (1 - lambda) I' with I'
// the CSQMI of a simulated sensor at the offered pose in the own map (through the team
// transform; unknown_transform_factor while unknown), normalised by the largest; the best are
// requested within what the links carry in one period. (The requester's own pose uncertainty
// is the same for every scan offered in a period, so in this normalised score it cannot change
// the choice; it is not used.)
//
// Footprints are a keyframe's voxel gains on an empty map summed over coarse blocks, computed
// once when the keyframe is made (MapInformation::scanGains and coarsened()).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "ccir_mapping/core/information/coverage.h"
#include "ccir_mapping/core/information/map_information.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/routing/fixed_rate_selector.h"
#include "ccir_mapping/core/routing/routing_messages.h"

namespace ccir_mapping::core::routing {

class CcirBroker {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors, a peer is this robot,
  /// or a peer is named twice.
  CcirBroker(std::string self, std::vector<std::string> peers, const BrokerParams& params);

  /// A keyframe's footprint: its scanFootprint on `map` summed over blocks of 2^3 voxels a side
  /// (0.8 m at 0.1 m), the unit the belief counts coverage in.
  static std::vector<information::VoxelGain> footprint(
      const information::MapInformation& map, const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
      const Pose3& map_from_sensor);

  /// The teammates (they may also be added later; adding one twice changes nothing).
  void addPeer(const std::string& name);
  /// Where an own keyframe at `odom_pose` is in the map frame: the newest optimised correction
  /// (map -> odom) applied to it.
  Pose3 placeOwn(const Pose3& odom_pose) const { return map_from_odom_ * odom_pose; }
  /// A new own keyframe: its stamp and odometry pose, its size on the wire and its footprint
  /// (at placeOwn(odom_pose)). Returns the ids no longer kept (the oldest beyond
  /// max_kept_scans).
  std::vector<KeyframeId> addKeyframe(KeyframeId id, Stamp stamp, const Pose3& odom_pose,
                                      std::size_t size_bytes,
                                      std::vector<information::VoxelGain> footprint);
  /// fixed_rate and all: true when a new keyframe goes to every teammate now (counted as sent
  /// to each known one); never in ccir.
  bool sendsToAll(KeyframeId id);

  /// Optimised sensor poses of own keyframes by stamp (the Backend's trajectory): the offers
  /// carry them, and the newest places keyframes made later.
  void setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses);
  /// Pose uncertainty u_k (a variance, m^2) of own keyframes from the pose graph.
  void setUncertainty(KeyframeId id, double variance_m2);
  /// c_k of own keyframe `id` with a keyframe of `peer`; the largest seen is kept.
  void setCorrespondences(const std::string& peer, KeyframeId id, int count);
  /// The teammate's map frame in this robot's map frame, or nullopt while it is not known.
  void setTeamTransform(const std::string& peer, const std::optional<Pose3>& map_from_peer);
  void setLink(const std::string& peer, const LinkState& link);

  /// The offer to `peer` for this period, or nullopt (nothing to offer, link down or busy).
  std::optional<Offer> makeOffer(const std::string& peer, double now_s);

  struct RequestOutcome {
    /// Own keyframe ids to send to the requester, in its order.
    std::vector<KeyframeId> send;
    /// Why the request or some of its ids were refused (empty when none was).
    std::map<std::string, int> refused;
  };
  /// A teammate's request: the ids to send, counted as sent.
  RequestOutcome onRequest(const Request& request, double now_s);
  /// Counts something refused outside the broker (e.g. a scan that could not be decoded).
  void countRefusal(const std::string& peer, const std::string& reason) { refuse(peer, reason); }
  /// A teammate acknowledges scans; false (counted) when it names this robot wrongly.
  bool onReceipt(const Receipt& receipt);

  /// An offer from a teammate, kept until chooseRequests(); false with the reason (counted)
  /// when it is not for this robot, from a stranger or longer than max_offer_scans.
  bool onOffer(const Offer& offer, std::string* reason = nullptr);
  /// The information (CSQMI) of a simulated sensor at a pose in this robot's map frame.
  using SensorInformation = std::function<double(const Pose3& sensor_pose)>;
  /// Requests for the offers received since the last call. An offered scan's information is
  /// asked at its pose through the provider's team transform, for providers whose transform is
  /// known. A scan requested less than receipt_timeout_s ago is not requested again (it may be
  /// on its way).
  std::vector<Request> chooseRequests(const SensorInformation& information, double now_s);
  /// A scan from a teammate; false for one received before (a duplicate, not acknowledged
  /// again) or from a stranger.
  bool onScanReceived(const std::string& provider, KeyframeId id, std::size_t size_bytes);
  /// ccir: the acknowledgements due (one per provider with new scans); none in other modes.
  std::vector<Receipt> takeReceipts();

  /// What one offer period sends: an offer to each teammate (makeOffer), requests for the
  /// offers received (chooseRequests), then the receipts due (takeReceipts).
  struct Period {
    std::vector<Offer> offers;
    std::vector<Request> requests;
    std::vector<Receipt> receipts;
  };
  Period runPeriod(const SensorInformation& information, double now_s);

  void addControlBytes(const std::string& peer, std::size_t bytes);
  /// An own keyframe's word set went to the teammates.
  void countFeaturesSent() { ++report_.features_sent; }
  /// The runtime-reconfigurable weights and fixed-rate n (mode and sizes stay).
  void setParams(const BrokerParams& params);
  const BrokerParams& params() const { return params_; }
  const std::map<std::string, PeerCounters>& counters() const { return counters_; }
  /// What the broker did since start (BrokerStats).
  BrokerReport report() const;

 private:
  struct Kept {
    Stamp stamp = 0;
    Pose3 odom_pose;
    Pose3 pose;
    std::size_t size_bytes = 0;
    std::vector<information::VoxelGain> footprint;
    octomap::OcTreeKey footprint_min, footprint_max;  // the blocks' bounding box
    double footprint_bits = 0.0;                      // its information to a map that knows nothing
    double variance_m2 = -1.0;                        // < 0: not known yet
  };
  struct Peer {
    LinkState link;
    bool link_known = false;
    /// Bytes sent since the link state was last reported (not in its queue count yet).
    std::size_t unreported_bytes = 0;
    /// The teammate's map frame in this robot's, once known.
    std::optional<Pose3> map_from_peer;
    std::map<KeyframeId, int> correspondences;
    /// Sent (with the time) and not acknowledged yet; acknowledged.
    std::map<KeyframeId, double> unacknowledged;
    std::set<KeyframeId> acknowledged;
    information::Coverage belief;
    /// belief.marginal of kept scans, computed once: the belief only grows by what is sent to
    /// the teammate, so a value holds until a scan whose footprint box meets it is sent.
    std::unordered_map<KeyframeId, double> marginals;
    std::uint32_t offer_sequence = 0;
    /// Ids offered and not sent since: what a request may ask for.
    std::set<KeyframeId> offered;
    // Requester side.
    std::optional<Offer> pending_offer;
    std::set<KeyframeId> received;
    std::map<KeyframeId, double> requested;  // when
    std::vector<KeyframeId> to_acknowledge;
  };

  bool holds(const Peer& peer, KeyframeId id) const;
  /// What kept scan `id` would add to the teammate's believed map (Peer::marginals).
  double marginal(Peer& peer, KeyframeId id, const Kept& kept) const;
  void markSent(const std::string& name, Peer& peer, KeyframeId id, double now_s);
  /// Scans sent too long ago without a receipt are taken as lost; the belief is rebuilt.
  void expireUnacknowledged(Peer& peer, double now_s);
  /// What one period on the link to `peer` carries, bytes (<= 0: nothing more fits).
  double periodCapacity(const Peer& peer) const;
  Peer* find(const std::string& name);
  void refuse(const std::string& peer, const std::string& reason, std::uint64_t n = 1);

  std::string self_;
  BrokerParams params_;
  std::map<std::string, Peer> peers_;
  std::map<std::string, PeerCounters> counters_;
  std::map<KeyframeId, Kept> kept_;
  std::map<Stamp, KeyframeId> kept_by_stamp_;
  Pose3 map_from_odom_ = Pose3::Identity();
  FixedRateSelector fixed_rate_;
  BrokerReport report_;  // the totals; report() adds the rest
};

}  // namespace ccir_mapping::core::routing
