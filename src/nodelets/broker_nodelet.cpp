// Broker: what this robot sends its teammates (those of its Bridge) and asks of them. It forwards
// the word sets, hands the rest to core::routing::BrokerStage (CCIR; requests are ranked with the
// map of the Mapper its `mapper` parameter names, shared in process) and sends what each step
// returns on the outbox.
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
  /// How long after start-up the Mapper's map may still be missing (nodelets load in no order).
  static constexpr double kMapperWaitS = 30.0;

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
    stage_ = std::make_unique<Stage>(robot(), peers, settings_.core, mapper->core,
                                     [this](const Stage::ControlMessage& m) {
                                       return std::visit(
                                           [this](const auto& c) {
                                             return serializationLength(toMsg(c));
                                           },
                                           m);
                                     });
    findMap();
    advertise<BrokerStats>(topics::kBrokerStats, topics::kLatestOnlyQueueSize);
    advertise<KeyframeFeatures>(topics::kOutboxFeatures, topics::kMessageQueueSize);
    advertise<SharedScan>(topics::kOutboxScans, topics::kKeyframeQueueSize);
    advertise<Keyframe>(topics::kTeammateScans, topics::kKeyframeQueueSize);

    const int queue = topics::kMessageQueueSize;
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &BrokerNodelet::onKeyframe);
    subscribe(topics::kInboxScans, topics::kKeyframeQueueSize, &BrokerNodelet::onScan);
    subscribe<KeyframeFeatures>(topics::kFeatures, queue, [this](const KeyframeFeatures::ConstPtr& msg) {
      ccir().countFeaturesSent();
      publish(topics::kOutboxFeatures, msg);
    });
    subscribe<Correspondences>(topics::kCorrespondences, queue, [this](const Correspondences& m) {
      const auto c = conversions::toKeyframeCorrespondences(m);
      if (!c) return drop("correspondences", "ids and counts differ in length");
      stage_->onCorrespondences(c->peer, c->counts);
    });
    subscribe<KeyframeUncertainty>(topics::kKeyframeUncertainty, 1, [this](const KeyframeUncertainty& m) {
      const auto variances = conversions::toVariances(m);
      if (!variances) return drop("keyframe_uncertainty", "ids and variances differ in length");
      for (const auto& [id, variance] : *variances) ccir().setUncertainty(id, variance);
    });
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
      if (!stage_->hasMap()) findMap();
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

  const std::string& robot() const { return settings_.frames.robot_name; }
  CcirBroker& ccir() { return stage_->ccir(); }

  /// The Mapper's map, from the process's registry; in mode ccir a Mapper that has not come up
  /// by kMapperWaitS after start-up is a configuration error (the nodelet stops).
  void findMap() {
    const std::string name = getNodeHandle().resolveName(settings_.mapper);
    if (auto map = core::information::SharedMap::find(name)) return stage_->setMap(std::move(map));
    if (settings_.core.mode != core::routing::RoutingMode::kCcir || mapper_check_.isValid()) return;
    mapper_check_ = getNodeHandle().createSteadyTimer(
        ros::WallDuration(kMapperWaitS),
        [this, name](const auto&) {
          if (stage_->hasMap()) return;
          stopWork();
          failConfiguration("mapper: no Mapper named " + name +
                            " runs in this manager (mode ccir ranks requests with its map)");
        },
        /*oneshot=*/true);
  }

  void onKeyframe(const Keyframe& keyframe) {
    core::routing::WireScan wire;
    pcl::PointCloud<pcl::PointXYZ> points;
    if (const auto error = measured("codec", [&] {
          return conversions::toWireScan(keyframe, settings_.core, &wire, &points);
        })) {
      return drop("keyframes", "not sharing keyframe %lu: %s",
                  static_cast<unsigned long>(keyframe.id), error->c_str());
    }
    const core::Pose3 pose = wire.odom_pose;
    const core::Stamp stamp = wire.stamp;
    auto shared = boost::make_shared<const SharedScan>(conversions::toSharedScanMsg(
        std::move(wire), keyframe.header.frame_id, keyframe.odom_frame));
    emit(measured("footprint", [&] {
      return stage_->addKeyframe(keyframe.id, stamp, pose, points, shared,
                                 serializationLength(*shared));
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

  ScanOffer toMsg(const core::routing::Offer& o) const {
    return conversions::toOfferMsg(o, settings_.frames.map_frame);
  }
  static ScanRequest toMsg(const core::routing::Request& r) { return conversions::toRequestMsg(r); }
  static ScanReceipt toMsg(const core::routing::Receipt& r) { return conversions::toReceiptMsg(r); }

  /// Sends what a step of the stage returned and reports what it refused.
  void emit(const Stage::Output& out) {
    for (const auto& refusal : out.refused) warnPerKind(refusal.kind, "%s", refusal.text.c_str());
    for (const auto& o : out.offers) send(o.requester, "offers", toMsg(o));
    for (const auto& r : out.requests) send(r.provider, "requests", toMsg(r));
    for (const auto& r : out.receipts) send(r.provider, "receipts", toMsg(r));
    for (const auto& [peer, scan] : out.scans)  // kept, not copied
      publish(peer.empty() ? topics::kOutboxScans : topics::outboxTo(peer, "scans"), scan);
  }

  template <class M>
  void send(const std::string& peer, const char* rest, M msg) {
    msg.header.stamp = ros::Time::now();
    publish(topics::outboxTo(peer, rest), boost::make_shared<const M>(std::move(msg)));
  }

  /// Seconds on the clock the offer timer follows (receipt timeouts compare against it).
  static double clockNow() { return ros::Time::now().toSec(); }

  ros_params::BrokerSettings settings_;
  std::unique_ptr<Stage> stage_;
  ros::SteadyTimer mapper_check_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BrokerNodelet, nodelet::Nodelet)
