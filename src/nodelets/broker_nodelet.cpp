// Broker: what this robot sends its teammates (those of its `bridge`) and asks of them. It
// forwards the word sets, hands the rest to core::routing::BrokerStage (CCIR, requests ranked by
// the map of its `mapper`, shared in process) and sends what each step returns on the outbox.
#include <nav_msgs/Path.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/routing/broker_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using conversions::toRequest;
using conversions::toStampedPoses;
using conversions::toTeamFrame;
using core::information::SharedMap;
using ros::serialization::serializationLength;

class BrokerNodelet final : public PipelineNodelet {
 private:
  using Stage = core::routing::BrokerStage<SharedScan::ConstPtr>;
  static constexpr double kMapperWaitS = 20.0;  // after start-up (nodelets load in no order)

  void onInit() override {
    if (!loadSettings(settings_)) return;
    const auto bridge = siblingSettings<ros_params::BridgeSettings>("bridge", settings_.bridge);
    const auto mapper = siblingSettings<ros_params::MapperSettings>("mapper", settings_.mapper);
    if (!bridge || !mapper) return;
    const auto peers = bridge->core.peerNames();
    for (const auto& peer : peers) {
      advertise<SharedScan>(topics::outboxTo(peer, "scans"), topics::kKeyframeQueueSize);
      advertise<ScanOffer>(topics::outboxTo(peer, "offers"), topics::kMessageQueueSize);
      advertise<ScanRequest>(topics::outboxTo(peer, "requests"), topics::kMessageQueueSize);
      advertise<ScanReceipt>(topics::outboxTo(peer, "receipts"), topics::kMessageQueueSize);
    }
    stage_ = std::make_unique<Stage>(
        settings_.frames.robot_name, peers, settings_.core, mapper->core, [this](const auto& m) {
          return conversions::serializedSize(m, settings_.frames.map_frame);
        });
    // The Mapper's map from the process's registry, once that Mapper runs (and at each period).
    mapper_ = getNodeHandle().resolveName(settings_.mapper);
    if (auto map = SharedMap::find(mapper_)) stage_->setMap(std::move(map));
    const std::string missing = "mapper: no Mapper named " + mapper_ + " runs in this manager";
    if (settings_.core.mode == core::routing::RoutingMode::kCcir)  // requests ranked by its map
      requireWithin(
          kMapperWaitS, [this] { return stage_->hasMap(); }, missing);
    advertise<BrokerStats>(topics::kBrokerStats, topics::kLatestOnlyQueueSize);
    advertise<KeyframeFeatures>(topics::kOutboxFeatures, topics::kMessageQueueSize);
    advertise<SharedScan>(topics::kOutboxScans, topics::kKeyframeQueueSize);
    advertise<Keyframe>(topics::kTeammateScans, topics::kKeyframeQueueSize);
    const int queue = topics::kMessageQueueSize;
    using Uncertainty = KeyframeUncertainty;
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &BrokerNodelet::onKeyframe);
    subscribe(topics::kInboxScans, topics::kKeyframeQueueSize, &BrokerNodelet::onScan);
    subscribe<KeyframeFeatures>(topics::kFeatures, queue,
                                [this](const KeyframeFeatures::ConstPtr& msg) {
                                  ccir().countFeaturesSent();
                                  publish(topics::kOutboxFeatures, msg);
                                });
    subscribe<Correspondences>(topics::kCorrespondences, queue, [this](const Correspondences& m) {
      const auto c = conversions::toKeyframeCorrespondences(m);
      if (!c) return drop("correspondences", "ids and counts differ in length");
      stage_->onCorrespondences(c->peer, c->counts);
    });
    subscribe<Uncertainty>(topics::kKeyframeUncertainty, 1, [this](const Uncertainty& m) {
      const auto variances = conversions::toVariances(m);
      if (!variances) return drop("keyframe_uncertainty", "ids and variances differ in length");
      for (const auto& [id, variance] : *variances) ccir().setUncertainty(id, variance);
    });
    subscribe(topics::kTrajectory, 1, &BrokerNodelet::onTrajectory);
    subscribe(topics::kTeamTransforms, queue, &BrokerNodelet::onTeamTransform);
    subscribe(topics::kLinkStats, queue, &BrokerNodelet::onLinkStats);
    subscribe<ScanOffer>(topics::kInboxOffers, queue, [this](const ScanOffer& m) {
      core::routing::Offer offer;
      const auto malformed = conversions::toOffer(m, &offer);
      emit(stage_->onOffer(offer, malformed));
    });
    subscribe(topics::kInboxRequests, queue, &BrokerNodelet::onRequest);
    subscribe(topics::kInboxReceipts, queue, &BrokerNodelet::onReceipt);
    createPeriodicTimer(settings_.core.offer_period_s, [this] {
      if (auto map = SharedMap::find(mapper_)) stage_->setMap(std::move(map));
      emit(measured("route", [this] { return stage_->runPeriod(now()); }));
    });
    createPeriodicTimer(settings_.core.stats_period_s, [this] {
      auto stats = conversions::toBrokerStatsMsg(ccir().report(), ros::Time::now());
      publish(topics::kBrokerStats, boost::make_shared<const BrokerStats>(std::move(stats)));
    });
    serveReconfigure(ros_params::brokerReconfigure(), settings_.core,
                     [this](const auto& params) { ccir().setParams(params); });
  }

  core::routing::CcirBroker& ccir() { return stage_->ccir(); }
  void onTrajectory(const nav_msgs::Path& m) { ccir().setOptimizedPoses(toStampedPoses(m)); }
  void onTeamTransform(const TeamTransform& m) { ccir().setTeamTransform(m.peer, toTeamFrame(m)); }
  void onLinkStats(const LinkStats& m) { ccir().setLink(m.peer, conversions::toLinkState(m)); }
  void onRequest(const ScanRequest& m) { emit(stage_->onRequest(toRequest(m), now())); }
  void onReceipt(const ScanReceipt& m) { emit(stage_->onReceipt(conversions::toReceipt(m))); }
  /// Seconds on the clock the offer timer follows (receipt timeouts compare against it).
  static double now() { return ros::Time::now().toSec(); }

  void onKeyframe(const Keyframe& k) {
    core::routing::WireScan wire;
    pcl::PointCloud<pcl::PointXYZ> points;
    const auto error = measured(
        "codec", [&] { return conversions::toWireScan(k, settings_.core, &wire, &points); });
    if (error) return drop("keyframes", "not sharing keyframe %lu: %s", k.id, error->c_str());
    const auto [stamp, pose] = std::pair(wire.stamp, wire.odom_pose);
    auto shared = boost::make_shared<const SharedScan>(
        conversions::toSharedScanMsg(std::move(wire), k.header.frame_id, k.odom_frame));
    emit(measured("footprint", [&] {
      return stage_->addKeyframe(k.id, stamp, pose, points, shared, serializationLength(*shared));
    }));
  }

  void onScan(const SharedScan& msg) {
    auto keyframe = boost::make_shared<Keyframe>();
    const auto undecodable =
        measured("codec", [&] { return conversions::toKeyframe(msg, keyframe.get()); });
    const auto out = stage_->onScan(msg.robot, msg.id, serializationLength(msg), undecodable);
    if (out.refused.empty()) publish(topics::kTeammateScans, keyframe);
    emit(out);  // refusals are counted by reason on broker_stats
  }

  /// Sends what a step of the stage returned and reports what it refused.
  void emit(const Stage::Output& out) {
    for (const auto& refusal : out.refused) warnPerKind(refusal.kind, "%s", refusal.text.c_str());
    const std::string& frame = settings_.frames.map_frame;
    for (const auto& o : out.offers) send(o.requester, "offers", conversions::toOfferMsg(o, frame));
    for (const auto& r : out.requests) send(r.provider, "requests", conversions::toRequestMsg(r));
    for (const auto& r : out.receipts) send(r.provider, "receipts", conversions::toReceiptMsg(r));
    for (const auto& [peer, scan] : out.scans)  // kept, not copied
      publish(peer.empty() ? topics::kOutboxScans : topics::outboxTo(peer, "scans"), scan);
  }
  template <class M>
  void send(const std::string& peer, const char* rest, M msg) {
    msg.header.stamp = ros::Time::now();
    publish(topics::outboxTo(peer, rest), boost::make_shared<const M>(std::move(msg)));
  }

  ros_params::BrokerSettings settings_;
  std::unique_ptr<Stage> stage_;
  std::string mapper_;  // the Mapper's resolved name
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BrokerNodelet, nodelet::Nodelet)
