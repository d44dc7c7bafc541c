// Broker: what this robot sends its teammates and asks of them (core::routing::CcirBroker). It
// forwards the word sets, keeps own keyframes in their wire form, makes offers, answers
// requests, chooses what to request from teammates' offers, decodes the scans they send onto
// teammate_scans and acknowledges them. The teammates are those of this robot's Bridge.
#include <map>
#include <mutex>

#include <dynamic_reconfigure/server.h>
#include <nav_msgs/Path.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/BrokerStats.h"
#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/KeyframeUncertainty.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/information/shared_map.h"
#include "ccir_mapping/core/routing/ccir_broker.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

namespace routing = core::routing;

namespace {

/// Where robot.launch puts the Bridge's and the Mapper's parameters (the teammates and the
/// map's resolution come from there).
constexpr char kBridgeNamespace[] = "bridge";
constexpr char kMapperNamespace[] = "mapper";
/// Most points a teammate's scan may decode to (a VLP-16 sweep has ~29 k before filtering).
constexpr std::size_t kMaxScanPoints = 1 << 20;

}  // namespace

class BrokerNodelet final : public PipelineNodelet {
 private:
  struct PeerOutbox {
    ros::Publisher offers, requests, receipts, scans;
  };

  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    ros_params::BridgeSettings bridge;
    if (!loadSiblingSettings(kBridgeNamespace, bridge)) {
      NODELET_WARN("the Bridge's parameters are invalid (it says why): no teammates to route to");
    }
    std::vector<std::string> peers;
    for (const auto& peer : bridge.core.peers) {
      peers.push_back(peer.name);
      auto& out = outboxes_[peer.name];
      out.offers = nh.advertise<ScanOffer>(topics::outboxTo(peer.name, "offers"), 50);
      out.requests = nh.advertise<ScanRequest>(topics::outboxTo(peer.name, "requests"), 50);
      out.receipts = nh.advertise<ScanReceipt>(topics::outboxTo(peer.name, "receipts"), 50);
      out.scans = nh.advertise<SharedScan>(topics::outboxTo(peer.name, "scans"),
                                           topics::kKeyframeQueueSize);
    }
    broker_ =
        std::make_unique<routing::CcirBroker>(settings_.frames.robot_name, peers, settings_.core);
    // Footprints need the map's parameters only, not its contents: an empty map of the
    // Mapper's settings.
    ros_params::MapperSettings mapper;
    loadSiblingSettings(kMapperNamespace, mapper);
    footprint_map_ = std::make_unique<core::information::OccupancyMap>(mapper.core);

    stats_pub_ = nh.advertise<BrokerStats>(topics::kBrokerStats, topics::kLatestOnlyQueueSize);
    features_pub_ =
        nh.advertise<KeyframeFeatures>(topics::kOutboxFeatures, topics::kMessageQueueSize);
    scans_pub_ = nh.advertise<SharedScan>(topics::kOutboxScans, topics::kKeyframeQueueSize);
    teammate_scans_pub_ =
        nh.advertise<Keyframe>(topics::kTeammateScans, topics::kKeyframeQueueSize);
    subscribe(topics::kKeyframes, &BrokerNodelet::onKeyframe, topics::kKeyframeQueueSize);
    subscribe(topics::kFeatures, &BrokerNodelet::onFeatures);
    subscribe(topics::kCorrespondences, &BrokerNodelet::onCorrespondences);
    subscribe(topics::kTrajectory, &BrokerNodelet::onTrajectory, 1);
    subscribe(topics::kKeyframeUncertainty, &BrokerNodelet::onUncertainty, 1);
    subscribe(topics::kTeamTransforms, &BrokerNodelet::onTeamTransform);
    subscribe(topics::kLinkStats, &BrokerNodelet::onLinkStats);
    subscribe(topics::kInboxOffers, &BrokerNodelet::onOffer);
    subscribe(topics::kInboxRequests, &BrokerNodelet::onRequest);
    subscribe(topics::kInboxReceipts, &BrokerNodelet::onReceipt);
    subscribe(topics::kInboxScans, &BrokerNodelet::onScan, topics::kKeyframeQueueSize);

    createPeriodicTimer(settings_.core.offer_period_s,
                        [this] { measured("route", [this] { route(); }); });
    createPeriodicTimer(settings_.core.stats_period_s, [this] { publishStats(); });
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<BrokerConfig>>(
        reconfigure_mutex_, getPrivateNodeHandle());
    reconfigure_->setCallback([this](BrokerConfig& config, uint32_t) { onReconfigure(config); });
  }

  template <class M>
  void subscribe(const char* topic,
                 void (BrokerNodelet::*callback)(const boost::shared_ptr<M const>&),
                 int queue = topics::kMessageQueueSize) {
    subs_.push_back(getNodeHandle().subscribe<M>(topic, queue, callback, this));
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    auto shared = boost::make_shared<SharedScan>();
    pcl::PointCloud<pcl::PointXYZ> points;
    core::Pose3 odom_pose;
    std::optional<std::string> error = conversions::toScanPoints(*keyframe, &points, &odom_pose);
    if (!error) {
      error = measured("codec", [&] { return conversions::toSharedScan(*keyframe, shared.get()); });
    }
    if (error) {
      NODELET_WARN_THROTTLE(5.0, "not sharing keyframe %lu: %s",
                            static_cast<unsigned long>(keyframe->id), error->c_str());
      count("dropped keyframes");
      return;
    }
    const std::size_t bytes = ros::serialization::serializationLength(*shared);
    std::lock_guard<std::mutex> lock(mutex_);
    ++keyframes_;
    auto footprint = measured("footprint", [&] {
      return routing::CcirBroker::footprint(*footprint_map_, points, broker_->placeOwn(odom_pose));
    });
    for (const auto id :
         broker_->addKeyframe(keyframe->id, conversions::toStamp(keyframe->header.stamp), odom_pose,
                              bytes, std::move(footprint))) {
      kept_.erase(id);
    }
    kept_[keyframe->id] = shared;
    if (broker_->sendsToAll(keyframe->id)) {
      count("out outbox/scans", bytes);
      ++scans_sent_;
      scans_pub_.publish(shared);
    }
  }

  void onFeatures(const KeyframeFeatures::ConstPtr& features) {
    count("in features");
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++features_sent_;
    }
    count("out outbox/features");
    features_pub_.publish(features);
  }

  void onCorrespondences(const Correspondences::ConstPtr& msg) {
    count("in correspondences");
    if (msg->keyframe_ids.size() != msg->counts.size()) {
      NODELET_WARN_THROTTLE(5.0, "ignoring correspondences for %s: %zu ids but %zu counts",
                            msg->peer.c_str(), msg->keyframe_ids.size(), msg->counts.size());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < msg->keyframe_ids.size(); ++i) {
      broker_->setCorrespondences(msg->peer, msg->keyframe_ids[i],
                                  static_cast<int>(msg->counts[i]));
    }
  }

  void onTrajectory(const nav_msgs::Path::ConstPtr& path) {
    const auto poses = conversions::toStampedPoses(*path);
    std::lock_guard<std::mutex> lock(mutex_);
    broker_->setOptimizedPoses(poses);
  }

  void onUncertainty(const KeyframeUncertainty::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::size_t n = std::min(msg->keyframe_ids.size(), msg->position_variance_m2.size());
    for (std::size_t i = 0; i < n; ++i) {
      broker_->setUncertainty(msg->keyframe_ids[i], msg->position_variance_m2[i]);
    }
  }

  void onTeamTransform(const TeamTransform::ConstPtr& msg) {
    const auto transform = conversions::toPose(msg->transform);
    std::lock_guard<std::mutex> lock(mutex_);
    broker_->setTransformKnown(msg->peer, msg->valid && transform);
    if (msg->valid && transform) {
      team_[msg->peer] = *transform;
    } else {
      team_.erase(msg->peer);
    }
  }

  void onLinkStats(const LinkStats::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    broker_->setLink(msg->peer, conversions::toLinkState(*msg));
  }

  void onOffer(const ScanOffer::ConstPtr& msg) {
    count("in inbox/offers");
    routing::Offer offer;
    std::string reason;
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto error = conversions::toOffer(*msg, &offer)) {
      reason = *error;
      broker_->countRefusal(msg->provider, "malformed_offer");
    } else if (broker_->onOffer(offer, &reason)) {
      return;
    }
    NODELET_WARN_THROTTLE(5.0, "refusing an offer from '%s': %s", msg->provider.c_str(),
                          reason.c_str());
  }

  void onRequest(const ScanRequest::ConstPtr& msg) {
    count("in inbox/requests");
    std::lock_guard<std::mutex> lock(mutex_);
    const auto outcome = broker_->onRequest(conversions::toRequest(*msg), clockNow());
    for (const auto& [reason, n] : outcome.refused) {
      NODELET_WARN_THROTTLE(5.0, "refusing %d scan(s) %s asked for: %s", n, msg->requester.c_str(),
                            reason.c_str());
    }
    const auto out = outboxes_.find(msg->requester);
    if (out == outboxes_.end()) return;  // not a teammate: refused above
    for (const auto id : outcome.send) {
      count("out outbox/to/" + msg->requester + "/scans");
      ++scans_sent_;
      out->second.scans.publish(kept_.at(id));  // kept, not copied
    }
  }

  void onReceipt(const ScanReceipt::ConstPtr& msg) {
    count("in inbox/receipts");
    std::lock_guard<std::mutex> lock(mutex_);
    if (!broker_->onReceipt(conversions::toReceipt(*msg))) {
      NODELET_WARN_THROTTLE(5.0, "refusing a receipt from '%s' for '%s'", msg->receiver.c_str(),
                            msg->provider.c_str());
    }
  }

  void onScan(const SharedScan::ConstPtr& msg) {
    count("in inbox/scans", msg->points.size());
    auto keyframe = boost::make_shared<Keyframe>();
    std::optional<std::string> error;
    if (msg->robot == settings_.frames.robot_name) error = "it is this robot's own (bridge loop?)";
    if (!error) {
      error = measured(
          "codec", [&] { return conversions::toKeyframe(*msg, kMaxScanPoints, keyframe.get()); });
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (error) {
      broker_->countRefusal(msg->robot, "undecodable_scan");
      NODELET_WARN_THROTTLE(5.0, "dropping scan %lu of '%s': %s",
                            static_cast<unsigned long>(msg->id), msg->robot.c_str(),
                            error->c_str());
      return;
    }
    if (!broker_->onScanReceived(msg->robot, msg->id,
                                 ros::serialization::serializationLength(*msg))) {
      NODELET_WARN_THROTTLE(5.0, "dropping scan %lu of '%s': received before, or not a teammate's",
                            static_cast<unsigned long>(msg->id), msg->robot.c_str());
      return;  // counted by reason on broker_stats
    }
    ++scans_received_;
    count("out teammate_scans");
    teammate_scans_pub_.publish(keyframe);
  }

  /// One offer period: offers to every teammate, requests from their offers, receipts.
  void route() {
    std::lock_guard<std::mutex> lock(mutex_);
    const double now = clockNow();
    for (auto& [peer, out] : outboxes_) {
      if (const auto offer = broker_->makeOffer(peer, now)) {
        publishControl(peer, out.offers,
                       conversions::toOfferMsg(*offer, settings_.frames.map_frame));
      }
    }
    const auto map = core::information::SharedMap::find(settings_.frames.robot_name);
    const auto information = [&](const std::string& provider, const routing::OfferEntry& scan) {
      const auto team = team_.find(provider);
      if (!map || team == team_.end()) return 0.0;
      return map->read([&](const core::information::MapInformation& m) {
        return m.simulatedCsqmi(team->second * scan.pose);
      });
    };
    for (const auto& request : broker_->chooseRequests(information, now)) {
      publishControl(request.provider, outboxes_.at(request.provider).requests,
                     conversions::toRequestMsg(request));
    }
    for (const auto& receipt : broker_->takeReceipts()) {
      publishControl(receipt.provider, outboxes_.at(receipt.provider).receipts,
                     conversions::toReceiptMsg(receipt));
    }
  }

  template <class M>
  void publishControl(const std::string& peer, ros::Publisher& publisher, M msg) {
    msg.header.stamp = ros::Time::now();
    const std::size_t bytes = ros::serialization::serializationLength(msg);
    broker_->addControlBytes(peer, bytes);
    count("out " + publisher.getTopic(), bytes);
    publisher.publish(boost::make_shared<M>(std::move(msg)));
  }

  /// Seconds on the clock the offer timer follows (receipt timeouts compare against it).
  double clockNow() const { return ros::Time::now().toSec(); }

  void publishStats() {
    auto stats = boost::make_shared<BrokerStats>();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stats->keyframes = keyframes_;
      stats->features_sent = features_sent_;
      stats->kept_scans = static_cast<std::uint32_t>(broker_->keptScans());
      for (const auto& [peer, c] : broker_->counters()) {
        stats->scan_bytes_sent += c.scan_bytes_sent;
        stats->scan_bytes_received += c.scan_bytes_received;
        stats->peers.push_back(conversions::toPeerRoutingMsg(peer, c));
      }
      stats->scans_sent = scans_sent_;
      stats->scans_received = scans_received_;
    }
    stats->header.stamp = ros::Time::now();
    stats->robot = settings_.frames.robot_name;
    stats->mode = routing::toString(settings_.core.mode);
    stats_pub_.publish(stats);
  }

  void onReconfigure(BrokerConfig& config) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto outcome = ros_params::brokerReconfigure().apply(config, settings_.core);
    if (outcome.error) {
      NODELET_ERROR("reconfigure rejected: %s", outcome.error->c_str());
      return;
    }
    if (!outcome.changes.empty()) NODELET_INFO("reconfigured:%s", outcome.changes.c_str());
    settings_.core = outcome.params;
    broker_->setParams(outcome.params);
  }

  ros_params::BrokerSettings settings_;
  /// Guards everything below it.
  std::mutex mutex_;
  std::unique_ptr<routing::CcirBroker> broker_;
  std::unique_ptr<core::information::OccupancyMap> footprint_map_;
  std::map<core::KeyframeId, SharedScan::ConstPtr> kept_;
  std::map<std::string, core::Pose3> team_;  // this robot's map <- a teammate's
  std::map<std::string, PeerOutbox> outboxes_;
  std::uint64_t keyframes_ = 0, features_sent_ = 0, scans_sent_ = 0, scans_received_ = 0;
  ros::Publisher stats_pub_, features_pub_, scans_pub_, teammate_scans_pub_;
  std::vector<ros::Subscriber> subs_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<BrokerConfig>> reconfigure_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BrokerNodelet, nodelet::Nodelet)
