#include "ccir_mapping/core/routing/ccir_broker.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "ccir_mapping/core/information/scan_ranker.h"

namespace ccir_mapping::core::routing {

namespace {

/// Below this a utility or score counts as nothing worth the link.
constexpr double kNegligible = 1e-9;
constexpr int kFootprintBlockLevels = 3;

}  // namespace

CcirBroker::CcirBroker(std::string self, std::vector<std::string> peers, const BrokerParams& params)
    : self_(std::move(self)), params_(params), fixed_rate_(params.fixed_rate_every_n) {
  report_.robot = self_;
  const auto errors = params.validate();
  if (!errors.empty()) throw std::invalid_argument("CcirBroker: " + errors.front());
  for (const auto& name : peers) {
    if (name == self_ || name.empty() || peers_.count(name)) {
      throw std::invalid_argument("CcirBroker: peer '" + name + "' is this robot or named twice");
    }
    peers_[name];
    counters_[name];
  }
}

CcirBroker::Peer* CcirBroker::find(const std::string& name) {
  const auto it = peers_.find(name);
  return it == peers_.end() ? nullptr : &it->second;
}

void CcirBroker::refuse(const std::string& peer, const std::string& reason, std::uint64_t n) {
  // Strangers are counted under "".
  counters_[peers_.count(peer) ? peer : std::string()].refused[reason] += n;
}

std::vector<information::VoxelGain> CcirBroker::footprint(
    const information::MapInformation& map, const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
    const Pose3& map_from_sensor) {
  return information::coarsened(map.scanFootprint(sensor_points, map_from_sensor),
                                kFootprintBlockLevels);
}

void CcirBroker::addPeer(const std::string& name) {
  if (name == self_ || name.empty() || peers_.count(name)) return;
  peers_[name];
  counters_[name];
}

std::vector<KeyframeId> CcirBroker::addKeyframe(KeyframeId id, Stamp stamp, const Pose3& odom_pose,
                                                std::size_t size_bytes,
                                                std::vector<information::VoxelGain> footprint) {
  ++report_.keyframes;
  Kept& kept = kept_[id];
  kept.stamp = stamp;
  kept.odom_pose = odom_pose;
  kept.pose = placeOwn(odom_pose);
  kept.size_bytes = size_bytes;
  kept.footprint = std::move(footprint);
  kept.footprint_bits = information::Coverage().marginal(kept.footprint);
  kept.footprint_min = kept.footprint_max = octomap::OcTreeKey(0, 0, 0);
  for (std::size_t i = 0; i < kept.footprint.size(); ++i) {
    const octomap::OcTreeKey& key = kept.footprint[i].first;
    for (int axis = 0; axis < 3; ++axis) {
      if (i == 0 || key[axis] < kept.footprint_min[axis]) kept.footprint_min[axis] = key[axis];
      if (i == 0 || key[axis] > kept.footprint_max[axis]) kept.footprint_max[axis] = key[axis];
    }
  }
  kept_by_stamp_[stamp] = id;
  std::vector<KeyframeId> evicted;
  while (kept_.size() > static_cast<std::size_t>(params_.max_kept_scans)) {
    const auto oldest = kept_.begin();
    evicted.push_back(oldest->first);
    kept_by_stamp_.erase(oldest->second.stamp);
    kept_.erase(oldest);
  }
  return evicted;
}

bool CcirBroker::sendsToAll(KeyframeId id) {
  const bool send = params_.mode == RoutingMode::kAll ||
                    (params_.mode == RoutingMode::kFixedRate && fixed_rate_.select());
  if (!send || !kept_.count(id)) return false;
  for (auto& [name, peer] : peers_) markSent(name, peer, id, 0.0);
  ++report_.scans_sent;
  return true;
}

void CcirBroker::setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses) {
  const Kept* newest = nullptr;
  for (const auto& [stamp, pose] : poses) {
    const auto id = kept_by_stamp_.find(stamp);
    if (id == kept_by_stamp_.end()) continue;
    Kept& kept = kept_.at(id->second);
    kept.pose = pose;
    if (!newest || kept.stamp > newest->stamp) newest = &kept;
  }
  if (newest) map_from_odom_ = newest->pose * newest->odom_pose.inverse();
}

void CcirBroker::setUncertainty(KeyframeId id, double variance_m2) {
  if (const auto it = kept_.find(id); it != kept_.end() && std::isfinite(variance_m2)) {
    it->second.variance_m2 = std::max(0.0, variance_m2);
  }
}

void CcirBroker::setCorrespondences(const std::string& name, KeyframeId id, int count) {
  if (Peer* peer = find(name)) {
    int& c = peer->correspondences[id];
    c = std::max(c, count);
  }
}

void CcirBroker::setTeamTransform(const std::string& name,
                                  const std::optional<Pose3>& map_from_peer) {
  if (Peer* peer = find(name)) peer->map_from_peer = map_from_peer;
}

void CcirBroker::setLink(const std::string& name, const LinkState& link) {
  if (Peer* peer = find(name)) {
    peer->link = link;
    peer->link_known = true;
    peer->unreported_bytes = 0;
  }
}

bool CcirBroker::holds(const Peer& peer, KeyframeId id) const {
  return peer.unacknowledged.count(id) || peer.acknowledged.count(id);
}

double CcirBroker::marginal(Peer& peer, KeyframeId id, const Kept& kept) const {
  const auto [it, added] = peer.marginals.try_emplace(id, 0.0);
  if (added) it->second = peer.belief.marginal(kept.footprint);
  return it->second;
}

void CcirBroker::markSent(const std::string& name, Peer& peer, KeyframeId id, double now_s) {
  const Kept& kept = kept_.at(id);
  peer.unacknowledged[id] = now_s;
  peer.offered.erase(id);
  peer.belief.add(kept.footprint);
  // What the belief gained lies in this footprint's box: values of scans whose box meets it
  // change (and of scans no longer kept go).
  for (auto it = peer.marginals.begin(); it != peer.marginals.end();) {
    const auto other = kept_.find(it->first);
    bool meets = other != kept_.end();
    for (int axis = 0; meets && axis < 3; ++axis) {
      meets = other->second.footprint_min[axis] <= kept.footprint_max[axis] &&
              kept.footprint_min[axis] <= other->second.footprint_max[axis];
    }
    it = meets || other == kept_.end() ? peer.marginals.erase(it) : std::next(it);
  }
  peer.unreported_bytes += kept.size_bytes;
  PeerCounters& c = counters_[name];
  ++c.scans_sent;
  c.scan_bytes_sent += kept.size_bytes;
}

void CcirBroker::expireUnacknowledged(Peer& peer, double now_s) {
  bool lost = false;
  for (auto it = peer.unacknowledged.begin(); it != peer.unacknowledged.end();) {
    if (now_s - it->second > params_.receipt_timeout_s) {
      it = peer.unacknowledged.erase(it);
      lost = true;
    } else {
      ++it;
    }
  }
  if (!lost) return;
  peer.belief.clear();
  peer.marginals.clear();
  for (const auto& [id, kept] : kept_) {
    if (holds(peer, id)) peer.belief.add(kept.footprint);
  }
}

double CcirBroker::periodCapacity(const Peer& peer) const {
  if (!peer.link_known || !peer.link.connected) return 0.0;
  const double rate = std::min(peer.link.budget_bytes_per_s,
                               peer.link.total_budget_bytes_per_s / double(peers_.size()));
  // What the buckets hold now (a link sharing the radio: its share of them) plus what they
  // refill in one period, less what waits ahead (control goes first) and what was sent since
  // the report.
  const double tokens =
      peer.link.available_tokens_bytes * rate / std::max(1.0, peer.link.budget_bytes_per_s);
  return tokens + rate * params_.offer_period_s - double(peer.link.queued_control_bytes) -
         double(peer.link.queued_bulk_bytes) - double(peer.unreported_bytes);
}

std::optional<Offer> CcirBroker::makeOffer(const std::string& name, double now_s) {
  Peer* peer = find(name);
  if (!peer || params_.mode != RoutingMode::kCcir || kept_.empty()) return std::nullopt;
  const std::size_t before = peer->unacknowledged.size();
  expireUnacknowledged(*peer, now_s);
  if (peer->unacknowledged.size() < before) {
    refuse(name, "unacknowledged", before - peer->unacknowledged.size());
  }
  const double capacity = periodCapacity(*peer);
  if (!(capacity > 0.0)) return std::nullopt;  // (NaN from a nonsense link state too)

  std::vector<KeyframeId> ids;
  std::vector<const Kept*> candidates;
  double total_bytes = 0.0;
  double max_variance = 0.0;
  for (const auto& [id, kept] : kept_) {
    total_bytes += double(kept.size_bytes);
    max_variance = std::max(max_variance, kept.variance_m2);
    if (holds(*peer, id)) continue;
    if (kept.footprint_bits <= 0.0 ||
        marginal(*peer, id, kept) < params_.min_novelty * kept.footprint_bits) {
      continue;  // the teammate knows (nearly) all it shows
    }
    ids.push_back(id);
    candidates.push_back(&kept);
  }
  if (ids.empty()) return std::nullopt;
  const double average_bytes = std::max(1.0, total_bytes / double(kept_.size()));
  const auto n = static_cast<std::size_t>(
      std::clamp(std::floor(capacity / average_bytes), 1.0, double(ids.size())));

  // F = c_k u_k / eta. A keyframe whose uncertainty is not known yet counts as the most
  // uncertain (it is the newest).
  std::vector<double> f(ids.size(), 0.0);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto c = peer->correspondences.find(ids[i]);
    if (c == peer->correspondences.end()) continue;
    double u = 1.0;
    if (peer->map_from_peer.has_value() && max_variance > 0.0) {
      u = candidates[i]->variance_m2 < 0.0 ? 1.0 : candidates[i]->variance_m2 / max_variance;
    }
    f[i] = double(c->second) * u;
  }
  const double eta = *std::max_element(f.begin(), f.end());
  for (double& v : f) v = eta > 0.0 ? v / eta : 0.0;

  const double lambda = params_.loop_closure_weight;
  const double k = peer->map_from_peer.has_value() ? 1.0 : params_.unknown_transform_factor;
  std::vector<double> marginals;
  for (std::size_t i = 0; i < ids.size(); ++i)
    marginals.push_back(marginal(*peer, ids[i], *candidates[i]));
  const double eta_i = lambda < 1.0 ? *std::max_element(marginals.begin(), marginals.end()) : 0.0;
  std::vector<std::pair<std::size_t, double>> chosen;  // (candidate, U)
  if (eta_i <= 0.0) {
    // Map information adds nothing: rank by F alone (the lower id first on ties).
    std::vector<std::size_t> order(ids.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return f[a] > f[b]; });
    for (std::size_t i = 0; i < std::min(n, order.size()); ++i) {
      chosen.emplace_back(order[i], lambda * f[order[i]]);
    }
  } else {
    // U scaled by eta_i / ((1 - lambda) k) is the ranker's objective: raw entropy drop plus a
    // bonus; the scale does not change the greedy order.
    const double scale = (1.0 - lambda) * k / eta_i;
    std::vector<const std::vector<information::VoxelGain>*> gains;
    std::vector<double> bonus;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      gains.push_back(&candidates[i]->footprint);
      bonus.push_back(lambda * f[i] / scale);
    }
    const auto bonus_of = [bonus](std::size_t i) { return bonus[i]; };
    const information::ScanRanker ranker(std::move(gains), std::move(bonus), &peer->belief,
                                         std::move(marginals));
    for (const auto& r : ranker.rankLazy(n)) {
      // What it adds beyond the picks before it, as a share of what it shows.
      const double novelty = (r.gain - bonus_of(r.index)) / candidates[r.index]->footprint_bits;
      if (novelty >= params_.min_novelty) chosen.emplace_back(r.index, r.gain * scale);
    }
  }

  Offer offer;
  offer.provider = self_;
  offer.requester = name;
  offer.sequence = ++peer->offer_sequence;
  std::set<KeyframeId> offered;
  for (const auto& [i, utility] : chosen) {
    if (utility <= kNegligible) continue;  // nothing the teammate would gain
    OfferEntry entry;
    entry.id = ids[i];
    entry.pose = candidates[i]->pose;
    const auto c = peer->correspondences.find(ids[i]);
    entry.correspondences = c == peer->correspondences.end() ? 0 : c->second;
    entry.size_bytes = candidates[i]->size_bytes;
    entry.utility = utility;
    offer.scans.push_back(entry);
    offered.insert(entry.id);
  }
  if (offer.scans.empty()) {
    --peer->offer_sequence;
    return std::nullopt;
  }
  peer->offered.insert(offered.begin(), offered.end());
  PeerCounters& c = counters_[name];
  ++c.offers_sent;
  c.scans_offered += offer.scans.size();
  return offer;
}

CcirBroker::RequestOutcome CcirBroker::onRequest(const Request& request, double now_s) {
  RequestOutcome outcome;
  Peer* peer = find(request.requester);
  const auto refuseAll = [&](const std::string& reason) {
    refuse(request.requester, reason);
    outcome.refused[reason] = static_cast<int>(request.ids.size());
    return outcome;
  };
  if (!peer) return refuseAll("unknown_robot");
  if (request.provider != self_) return refuseAll("not_for_this_robot");
  PeerCounters& c = counters_[request.requester];
  ++c.requests_received;
  c.scans_requested_by_peer += request.ids.size();
  // A request may answer an older offer than the last (it crossed newer ones on the link): any
  // id offered and not sent since is served.
  if (request.offer_sequence == 0 || request.offer_sequence > peer->offer_sequence) {
    return refuseAll("unknown_offer");
  }
  if (request.ids.size() > peer->offered.size()) return refuseAll("oversized");
  for (const KeyframeId id : request.ids) {
    const char* reason = nullptr;
    if (holds(*peer, id)) {
      reason = "already_sent";
    } else if (!peer->offered.count(id)) {
      reason = "not_offered";
    } else if (!kept_.count(id)) {
      reason = "evicted";
    }
    if (reason) {
      ++outcome.refused[reason];
      refuse(request.requester, reason);
      continue;
    }
    markSent(request.requester, *peer, id, now_s);
    outcome.send.push_back(id);
  }
  report_.scans_sent += outcome.send.size();
  return outcome;
}

bool CcirBroker::onReceipt(const Receipt& receipt) {
  Peer* peer = find(receipt.receiver);
  if (!peer || receipt.provider != self_) {
    refuse(receipt.receiver, peer ? "not_for_this_robot" : "unknown_robot");
    return false;
  }
  ++counters_[receipt.receiver].receipts_received;
  for (const KeyframeId id : receipt.ids) {
    if (peer->unacknowledged.erase(id)) {
      peer->acknowledged.insert(id);
    } else if (!peer->acknowledged.count(id)) {
      refuse(receipt.receiver, "receipt_for_unsent");
    }
  }
  return true;
}

bool CcirBroker::onOffer(const Offer& offer, std::string* reason) {
  Peer* peer = find(offer.provider);
  std::string why;
  if (!peer) {
    why = "unknown_robot";
  } else if (offer.requester != self_) {
    why = "not_for_this_robot";
  } else if (offer.scans.size() > static_cast<std::size_t>(params_.max_offer_scans)) {
    why = "oversized";
  }
  if (!why.empty()) {
    refuse(offer.provider, why);
    if (reason) *reason = why;
    return false;
  }
  PeerCounters& c = counters_[offer.provider];
  ++c.offers_received;
  c.scans_in_offers_received += offer.scans.size();
  peer->pending_offer = offer;  // a newer offer supersedes one not answered yet
  return true;
}

std::vector<Request> CcirBroker::chooseRequests(const SensorInformation& information,
                                                double now_s) {
  struct Scored {
    std::string provider;
    const OfferEntry* entry;
    double csqmi;
    double score;
  };
  std::vector<Scored> scored;
  double c_max = 0.0, csqmi_max = 0.0;
  for (auto& [name, peer] : peers_) {
    if (!peer.pending_offer) continue;
    for (const auto& entry : peer.pending_offer->scans) {
      if (peer.received.count(entry.id)) continue;
      const auto asked = peer.requested.find(entry.id);
      if (asked != peer.requested.end() && now_s - asked->second < params_.receipt_timeout_s) {
        continue;
      }
      const double csqmi =
          peer.map_from_peer ? std::max(0.0, information(*peer.map_from_peer * entry.pose)) : 0.0;
      scored.push_back({name, &entry, csqmi, 0.0});
      c_max = std::max(c_max, double(entry.correspondences));
      csqmi_max = std::max(csqmi_max, csqmi);
    }
  }
  const double lambda = params_.loop_closure_weight;
  for (Scored& s : scored) {
    const double f = c_max > 0.0 ? s.entry->correspondences / c_max : 0.0;
    const double i = peers_.at(s.provider).map_from_peer
                         ? (csqmi_max > 0.0 ? s.csqmi / csqmi_max : 0.0)
                         : params_.unknown_transform_factor;
    s.score = lambda * f + (1.0 - lambda) * i;
  }
  std::stable_sort(scored.begin(), scored.end(),
                   [](const Scored& a, const Scored& b) { return a.score > b.score; });

  // What the links carry in one period: per provider its link's share, and the radio's total.
  std::map<std::string, double> bytes;
  double total = 0.0;
  std::map<std::string, Request> requests;
  for (const Scored& s : scored) {
    if (s.score <= kNegligible) break;
    const Peer& peer = peers_.at(s.provider);
    const double link_rate =
        peer.link_known ? std::min(peer.link.budget_bytes_per_s,
                                   peer.link.total_budget_bytes_per_s / double(peers_.size()))
                        : 0.0;
    const double total_rate = peer.link_known ? peer.link.total_budget_bytes_per_s : 0.0;
    const double size = double(s.entry->size_bytes);
    double& mine = bytes[s.provider];
    // One scan per provider and period always fits: a scan larger than a period's budget
    // still goes, over several periods.
    if (mine > 0.0 && mine + size > link_rate * params_.offer_period_s) continue;
    if (total > 0.0 && total + size > total_rate * params_.offer_period_s) continue;
    mine += size;
    total += size;
    Request& request = requests[s.provider];
    request.requester = self_;
    request.provider = s.provider;
    request.offer_sequence = peer.pending_offer->sequence;
    request.ids.push_back(s.entry->id);
    peers_.at(s.provider).requested[s.entry->id] = now_s;
  }
  std::vector<Request> result;
  for (auto& [name, request] : requests) {
    PeerCounters& c = counters_[name];
    ++c.requests_sent;
    c.scans_requested += request.ids.size();
    result.push_back(std::move(request));
  }
  for (auto& [name, peer] : peers_) peer.pending_offer.reset();
  return result;
}

bool CcirBroker::onScanReceived(const std::string& provider, KeyframeId id,
                                std::size_t size_bytes) {
  Peer* peer = find(provider);
  if (!peer) {
    refuse(provider, "unknown_robot");
    return false;
  }
  peer->requested.erase(id);
  if (!peer->received.insert(id).second) {
    refuse(provider, "duplicate_scan");
    return false;
  }
  ++report_.scans_received;
  PeerCounters& c = counters_[provider];
  ++c.scans_received;
  c.scan_bytes_received += size_bytes;
  if (params_.mode == RoutingMode::kCcir) peer->to_acknowledge.push_back(id);
  return true;
}

std::vector<Receipt> CcirBroker::takeReceipts() {
  std::vector<Receipt> receipts;
  for (auto& [name, peer] : peers_) {
    if (peer.to_acknowledge.empty()) continue;
    receipts.push_back({self_, name, std::move(peer.to_acknowledge)});
    peer.to_acknowledge.clear();
    ++counters_[name].receipts_sent;
  }
  return receipts;
}

CcirBroker::Period CcirBroker::runPeriod(const SensorInformation& information, double now_s) {
  Period period;
  for (const auto& [name, peer] : peers_) {
    if (auto offer = makeOffer(name, now_s)) period.offers.push_back(std::move(*offer));
  }
  period.requests = chooseRequests(information, now_s);
  period.receipts = takeReceipts();
  return period;
}

void CcirBroker::addControlBytes(const std::string& peer, std::size_t bytes) {
  counters_[peers_.count(peer) ? peer : std::string()].control_bytes_sent += bytes;
}

BrokerReport CcirBroker::report() const {
  BrokerReport report = report_;
  report.mode = params_.mode;
  report.kept_scans = kept_.size();
  report.peers = counters_;
  return report;
}

void CcirBroker::setParams(const BrokerParams& params) {
  const auto errors = params.validate();
  if (!errors.empty()) throw std::invalid_argument("CcirBroker: " + errors.front());
  params_.loop_closure_weight = params.loop_closure_weight;
  params_.unknown_transform_factor = params.unknown_transform_factor;
  params_.fixed_rate_every_n = params.fixed_rate_every_n;
  fixed_rate_.setEveryN(params.fixed_rate_every_n);
}

}  // namespace ccir_mapping::core::routing
