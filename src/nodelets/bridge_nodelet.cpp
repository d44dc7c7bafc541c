// Bridge: carries the outbox topics to teammates' ROS masters and republishes theirs on the
// inbox (names: ros/topic_routes.h). Any message type: subscribed as topic_tools::ShapeShifter
// (type, md5, definition and latching come from the publisher's connection header) and
// republished from the bytes and that description. The network side is
// core::transport::BridgeStage; this nodelet converts and reports.
#include <topic_tools/shape_shifter.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/common/rate_meter.h"
#include "ccir_mapping/core/transport/bridge_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topic_routes.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

namespace transport = core::transport;
using topic_tools::ShapeShifter;

class BridgeNodelet final : public PipelineNodelet {
 private:
  /// A new inbox topic holds its first messages this long, while subscribers connect.
  static constexpr double kNewTopicHoldS = 0.5;

  void onInit() override {
    if (!loadSettings(settings_)) return;
    inboxes_ = std::make_unique<Inboxes>(
        [this](const std::string& topic, const ShapeShifter::ConstPtr& first, bool latched) {
          return first->advertise(getNodeHandle(), topic, topics::kInboxQueueSize, latched);
        },
        kNewTopicHoldS);
    try {
      bridge_ = std::make_unique<transport::BridgeStage>(
          settings_.core, settings_.frames.robot_name,
          [this](const std::string& peer, transport::InboxMessage m) { onInbox(peer, m); },
          [this](bool warning, const std::string& text) {
            // A link comes up at most once per redial (>= reconnect_min_s); refusals can come
            // as fast as a stranger connects.
            if (warning) {
              NODELET_WARN_THROTTLE(1.0, "%s", text.c_str());
            } else {
              NODELET_INFO("%s", text.c_str());
            }
          },
          clock());
      bridge_->start();
    } catch (const std::exception& e) {
      bridge_.reset();
      return failConfiguration(e.what());
    }
    advertise<LinkStats>(topics::kLinkStats, topics::kMessageQueueSize);
    for (const auto& forwarded : settings_.core.topics) {
      for (const auto& route : topics::outboxRoutes(forwarded.topic, settings_.core.peerNames())) {
        subscribeOutbox(forwarded, route);
      }
    }
    if (settings_.core.peers.empty()) NODELET_INFO("no peers configured: nothing is sent");
    createPeriodicTimer(settings_.core.stats_period_s, [this] { publishStats(); });
    flush_timer_ = getNodeHandle().createSteadyTimer(ros::WallDuration(0.1), [this](const auto&) {
      inboxes_->flush(ros::WallTime::now().toSec());
    });
  }

  void subscribeOutbox(const transport::ForwardedTopic& forwarded,
                       const topics::OutboxRoute& route) {
    // Subscribed for the whole event: a lambda handed to subscribe<M>() binds to the ConstPtr
    // overload and loses the connection header (and with it the latching flag).
    using Event = const ros::MessageEvent<ShapeShifter const>&;
    ros::SubscribeOptions options;
    options.initByFullCallbackType<Event>(
        route.outbox, topics::kMessageQueueSize, [this, forwarded, route](Event event) {
          const ShapeShifter& msg = *event.getConstMessage();
          count("in " + route.outbox, msg.size());
          const auto topic =
              conversions::toTopicInfo(msg, forwarded, event.getConnectionHeaderPtr().get());
          if (!bridge_->publish(topic, conversions::toBytes(msg), route.peer)) {
            drop(forwarded.topic + " (another type)",
                 "not forwarding %s: its type is now %s, teammates know it as another",
                 forwarded.topic.c_str(), topic.type.c_str());
          }
        });
    outbox_subscribers_.push_back(getNodeHandle().subscribe(options));
  }

  // On the bridge's thread.
  void onInbox(const std::string& peer, const transport::InboxMessage& message) {
    std::string error;
    const auto names = topics::inboxRepublished(message.topic.name, peer, &error);
    const auto msg = names ? conversions::toShapeShifter(message, &error) : nullptr;
    if (!msg) {
      return drop("from " + peer, "dropping a message from %s on '%s': %s", peer.c_str(),
                  message.topic.name.c_str(), error.c_str());
    }
    count("in " + message.topic.name + " from " + peer, message.bytes.size());
    // On the common inbox topic (the protocol's messages name their robot) and on one that
    // names the sender, for any type.
    for (const std::string& name : *names) {
      if (!inboxes_->publish(name, message.topic.md5, message.topic.latched, msg,
                             ros::WallTime::now().toSec())) {
        drop(name + " (another type)", "dropping %s from %s on %s: another type than before",
             message.topic.type.c_str(), peer.c_str(), name.c_str());
      }
    }
  }

  /// Replaying, the budgets hold per mission second (MissionClock), so that a replay at any
  /// speed sends what the robots would have sent; live, the bridge keeps its monotonic clock.
  static transport::BridgeStage::Clock clock() {
    if (!ros::Time::isSimTime()) return {};
    // The bridge calls it under its own lock.
    return [reader = std::make_shared<MissionClockReader>()] { return reader->now(); };
  }

  void publishStats() {
    const ros::Time now = ros::Time::now();
    for (const auto& report : bridge_->reports()) {
      // Per second of the bridge's clock (mission time while replaying; the wall clock once
      // the replay has ended and the queues drain).
      const double rate = send_rate_.rate(report.peer, report.at_s, report.sent.bytes_sent);
      publish(topics::kLinkStats,
              boost::make_shared<const LinkStats>(conversions::toLinkStatsMsg(
                  report, settings_.frames.robot_name, settings_.core, now, rate)));
    }
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    if (!bridge_) return;
    for (const auto& report : bridge_->reports()) {
      if (report.peer.empty()) continue;
      status.add("link " + report.peer,
                 std::string(report.connected ? "connected " : "down ") + report.address);
    }
  }

  using Inboxes = transport::InboxPublishers<ShapeShifter::ConstPtr, ros::Publisher>;
  ros_params::BridgeSettings settings_;
  std::vector<ros::Subscriber> outbox_subscribers_;
  ros::SteadyTimer flush_timer_;
  core::RateMeter send_rate_;  // bytes sent per link
  std::unique_ptr<Inboxes> inboxes_;
  // Last, so it is destroyed first: its thread calls onInbox.
  std::unique_ptr<transport::BridgeStage> bridge_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BridgeNodelet, nodelet::Nodelet)
