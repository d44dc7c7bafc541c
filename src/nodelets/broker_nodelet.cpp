// Broker: what this robot sends its teammates (those of its Bridge) and asks of them. It forwards
// the word sets, hands the rest to core::routing::BrokerStage (CCIR; requests are chosen with the
// map the Mapper shares in process) and sends what each step returns on the outbox.
#include <nav_msgs/Path.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/routing/broker_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::routing::CcirBroker;
using ros::serialization::serializationLength;

class BrokerNodelet final : public PipelineNodelet {
 private:
  using Stage = core::routing::BrokerStage<SharedScan::ConstPtr>;

  void onInit() override {
    if (!loadSettings(settings_)) return;
    const auto peers = siblingSettings<ros_params::BridgeSettings>("bridge").core.peerNames();
    for (const auto& peer : peers) {
      advertise<SharedScan>(topics::outboxTo(peer, "scans"), topics::kKeyframeQueueSize);
      advertise<ScanOffer>(topics::outboxTo(peer, "offers"), topics::kMessageQueueSize);
      advertise<ScanRequest>(topics::outboxTo(peer, "requests"), topics::kMessageQueueSize);
      advertise<ScanReceipt>(topics::outboxTo(peer, "receipts"), topics::kMessageQueueSize);
    }
    stage_ = std::make_unique<Stage>(settings_.frames.robot_name, peers, settings_.core,
                                     siblingSettings<ros_params::MapperSettings>("mapper").core);
    advertise<BrokerStats>(topics::kBrokerStats, topics::kLatestOnlyQueueSize);
    advertise<KeyframeFeatures>(topics::kOutboxFeatures, topics::kMessageQueueSize);
    advertise<SharedScan>(topics::kOutboxScans, topics::kKeyframeQueueSize);
    advertise<Keyframe>(topics::kTeammateScans, topics::kKeyframeQueueSize);

    const int queue = topics::kMessageQueueSize;
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &BrokerNodelet::onKeyframe);
    subscribe(topics::kInboxScans, topics::kKeyframeQueueSize, &BrokerNodelet::onScan);
    subscribe(topics::kFeatures, queue, &BrokerNodelet::onFeatures);
    subscribe(topics::kCorrespondences, queue, &BrokerNodelet::onCorrespondences);
    subscribe(topics::kKeyframeUncertainty, 1, &BrokerNodelet::onUncertainty);
    subscribe<nav_msgs::Path>(topics::kTrajectory, 1, [this](const nav_msgs::Path& m) {
      ccir().setOptimizedPoses(conversions::toStampedPoses(m));
    });
    subscribe<TeamTransform>(topics::kTeamTransforms, queue, [this](const TeamTransform& m) {
      ccir().setTeamTransform(m.peer, conversions::toTeamFrame(m));
    });
    subscribe<LinkStats>(topics::kLinkStats, queue, [this](const LinkStats& m) {
      ccir().setLink(m.peer, conversions::toLinkState(m));
    });
    subscribe<ScanOffer>(topics::kInboxOffers, queue, [this](const ScanOffer& m) {
      core::routing::Offer offer;
      const auto malformed = conversions::toOffer(m, &offer);
      emit(stage_->onOffer(offer, malformed));
    });
    subscribe<ScanRequest>(topics::kInboxRequests, queue, [this](const ScanRequest& m) {
      emit(stage_->onRequest(conversions::toRequest(m), clockNow()));
    });
    subscribe<ScanReceipt>(topics::kInboxReceipts, queue, [this](const ScanReceipt& m) {
      emit(stage_->onReceipt(conversions::toReceipt(m)));
    });
    createPeriodicTimer(settings_.core.offer_period_s, [this] {
      emit(measured("route", [this] { return stage_->runPeriod(clockNow()); }));
    });
    createPeriodicTimer(settings_.core.stats_period_s, [this] {
      publish(topics::kBrokerStats,
              boost::make_shared<const BrokerStats>(
                  conversions::toBrokerStatsMsg(ccir().report(), ros::Time::now())));
    });
    serveReconfigure(ros_params::brokerReconfigure(), settings_.core,
                     [this](const auto& params) { ccir().setParams(params); });
  }

  CcirBroker& ccir() { return stage_->ccir(); }

  void onFeatures(const KeyframeFeatures::ConstPtr& msg) {
    ccir().countFeaturesSent();
    publish(topics::kOutboxFeatures, msg);
  }
  void onCorrespondences(const Correspondences& msg) {
    const auto counts = conversions::toCorrespondenceCounts(msg);
    if (!counts) return drop("correspondences", "ids and counts differ in length");
    for (const auto& [id, c] : *counts) ccir().setCorrespondences(msg.peer, id, c);
  }
  void onUncertainty(const KeyframeUncertainty& msg) {
    const auto variances = conversions::toVariances(msg);
    if (!variances) return drop("keyframe_uncertainty", "ids and variances differ in length");
    for (const auto& [id, variance] : *variances) ccir().setUncertainty(id, variance);
  }

  void onKeyframe(const Keyframe& keyframe) {
    auto shared = boost::make_shared<SharedScan>();
    pcl::PointCloud<pcl::PointXYZ> points;
    core::Pose3 pose;
    if (const auto error = measured("codec", [&] {
          return conversions::toSharedScan(keyframe, settings_.core, shared.get(), &points, &pose);
        })) {
      return drop("keyframes", "not sharing keyframe %lu: %s",
                  static_cast<unsigned long>(keyframe.id), error->c_str());
    }
    emit(measured("footprint", [&] {
      return stage_->addKeyframe(keyframe.id, conversions::toStamp(keyframe.header.stamp), pose,
                                 points, shared, serializationLength(*shared));
    }));
  }

  void onScan(const SharedScan& msg) {
    auto keyframe = boost::make_shared<Keyframe>();
    const auto undecodable = measured("codec", [&] {
      return conversions::toKeyframe(msg, conversions::kMaxTeammateScanPoints, keyframe.get());
    });
    const auto out = stage_->onScan(msg.robot, msg.id, serializationLength(msg), undecodable);
    if (out.refused.empty()) publish(topics::kTeammateScans, keyframe);
    emit(out);  // refusals are counted by reason on broker_stats
  }

  /// Sends what a step of the stage returned and reports what it refused.
  void emit(const Stage::Output& out) {
    for (const auto& refusal : out.refused) warnPerKind(refusal.kind, "%s", refusal.text.c_str());
    for (const auto& o : out.offers)
      sendControl(o.requester, "offers", conversions::toOfferMsg(o, settings_.frames.map_frame));
    for (const auto& r : out.requests)
      sendControl(r.provider, "requests", conversions::toRequestMsg(r));
    for (const auto& r : out.receipts)
      sendControl(r.provider, "receipts", conversions::toReceiptMsg(r));
    for (const auto& [peer, scan] : out.scans)  // kept, not copied
      publish(peer.empty() ? topics::kOutboxScans : topics::outboxTo(peer, "scans"), scan);
  }

  template <class M>
  void sendControl(const std::string& peer, const char* rest, M msg) {
    msg.header.stamp = ros::Time::now();
    ccir().addControlBytes(peer, serializationLength(msg));
    publish(topics::outboxTo(peer, rest), boost::make_shared<const M>(std::move(msg)));
  }

  /// Seconds on the clock the offer timer follows (receipt timeouts compare against it).
  static double clockNow() { return ros::Time::now().toSec(); }

  ros_params::BrokerSettings settings_;
  std::unique_ptr<Stage> stage_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BrokerNodelet, nodelet::Nodelet)
