// Bridge: carries the outbox topics to teammates' ROS masters and republishes theirs on the
// inbox. Any message type: subscribed as topic_tools::ShapeShifter (type, md5, definition and
// latching come from the publisher's connection header) and republished from the bytes and that
// description. The network side is core::transport::Bridge; this nodelet converts and reports.
#include <deque>
#include <map>
#include <mutex>

#include <ros/names.h>
#include <topic_tools/shape_shifter.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/core/transport/bridge.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {
namespace transport = core::transport;

namespace {

// A new inbox publisher holds its first messages this long, so subscribers in other processes
// have connected before they go out (roscpp connects them asynchronously).
constexpr double kNewPublisherHoldS = 0.5;

}  // namespace

class BridgeNodelet final : public PipelineNodelet {
 private:
  struct Inbox {
    ros::Publisher publisher;
    std::string md5;
    ros::WallTime ready;
    std::deque<topic_tools::ShapeShifter::ConstPtr> held;
  };

  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    try {
      bridge_ = std::make_unique<transport::Bridge>(
          settings_.core, settings_.frames.robot_name,
          [this](const std::string& peer, transport::InboxMessage message) {
            onInbox(peer, std::move(message));
          },
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
      failConfiguration(e.what());
      return;
    }
    stats_pub_ = nh.advertise<LinkStats>(topics::kLinkStats, topics::kMessageQueueSize);
    for (const auto& forwarded : settings_.core.topics) {
      // "outbox/X" goes to every peer; "outbox/to/<peer>/X" to that peer alone, as "inbox/X"
      // (the Broker addresses offers, requests, receipts and scans).
      const std::string rest = forwarded.topic.substr(std::string("outbox/").size());
      subscribeOutbox(forwarded.topic, forwarded, "");
      for (const auto& peer : settings_.core.peers)
        subscribeOutbox(topics::outboxTo(peer.name, rest), forwarded, peer.name);
    }
    if (settings_.core.peers.empty()) NODELET_INFO("no peers configured: nothing is sent");
    createPeriodicTimer(settings_.core.stats_period_s, [this] { publishStats(); });
    flush_timer_ = nh.createSteadyTimer(ros::WallDuration(0.1), &BridgeNodelet::onFlushTimer, this);
  }

  void subscribeOutbox(const std::string& name, const transport::ForwardedTopic& forwarded,
                       const std::string& peer) {
    // Subscribed for the whole event: a lambda handed to subscribe<M>() binds to the ConstPtr
    // overload and loses the connection header (and with it the latching flag).
    using Event = const ros::MessageEvent<topic_tools::ShapeShifter const>&;
    ros::SubscribeOptions options;
    options.initByFullCallbackType<Event>(
        name, topics::kMessageQueueSize,
        [this, forwarded, peer](Event event) { onOutbox(forwarded, peer, event); });
    subs_.push_back(getNodeHandle().subscribe(options));
  }

  void onOutbox(const transport::ForwardedTopic& forwarded, const std::string& peer,
                const ros::MessageEvent<topic_tools::ShapeShifter const>& event) {
    const topic_tools::ShapeShifter& msg = *event.getConstMessage();
    const std::string rest = forwarded.topic.substr(std::string("outbox/").size());
    count("in " + (peer.empty() ? forwarded.topic : topics::outboxTo(peer, rest)), msg.size());
    transport::TopicInfo topic;
    topic.name = "inbox/" + rest;
    topic.type = msg.getDataType();
    topic.md5 = msg.getMD5Sum();
    topic.definition = msg.getMessageDefinition();
    const auto header = event.getConnectionHeaderPtr();
    topic.latched = header && header->count("latching") && header->at("latching") == "1";
    topic.reliable = forwarded.reliable;
    topic.compressed = forwarded.compress;
    topic.policy = forwarded.policy;
    std::vector<std::uint8_t> bytes(msg.size());
    ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    msg.write(stream);
    if (!bridge_->publish(topic, std::move(bytes), peer)) {
      NODELET_WARN_THROTTLE(5.0,
                            "not forwarding %s: its type is now %s, teammates know it as another",
                            forwarded.topic.c_str(), topic.type.c_str());
      count("dropped " + forwarded.topic + " (another type)");
    }
  }

  // On the bridge's thread.
  void onInbox(const std::string& peer, transport::InboxMessage message) {
    const transport::TopicInfo& topic = message.topic;
    std::string error;
    if (topic.name.rfind("inbox/", 0) != 0 || topic.name.find("..") != std::string::npos ||
        !ros::names::validate(topic.name, error)) {
      NODELET_WARN_THROTTLE(5.0, "dropping a message from %s on '%s': not a topic under inbox/",
                            peer.c_str(), topic.name.c_str());
      count("dropped from " + peer);
      return;
    }
    if (topic.type.find('/') == std::string::npos || topic.md5.size() != 32) {
      NODELET_WARN_THROTTLE(5.0, "dropping a message from %s on %s: type '%s', md5 '%s'",
                            peer.c_str(), topic.name.c_str(), topic.type.c_str(),
                            topic.md5.c_str());
      count("dropped from " + peer);
      return;
    }
    auto msg = boost::make_shared<topic_tools::ShapeShifter>();
    msg->morph(topic.md5, topic.type, topic.definition, topic.latched ? "1" : "0");
    ros::serialization::IStream stream(message.bytes.data(),
                                       static_cast<std::uint32_t>(message.bytes.size()));
    msg->read(stream);
    count("in " + topic.name + " from " + peer, message.bytes.size());
    // On the common inbox topic (the protocol's messages name their robot) and on one that
    // names the sender, for any type.
    const std::string rest = topic.name.substr(std::string("inbox/").size());
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    for (const std::string& name : {topic.name, "inbox/" + peer + "/" + rest}) {
      auto it = inboxes_.find(name);
      if (it == inboxes_.end()) {
        Inbox inbox;
        inbox.publisher =
            msg->advertise(getNodeHandle(), name, topics::kKeyframeQueueSize, topic.latched);
        inbox.md5 = topic.md5;
        inbox.ready = ros::WallTime::now() + ros::WallDuration(kNewPublisherHoldS);
        it = inboxes_.emplace(name, std::move(inbox)).first;
      }
      Inbox& inbox = it->second;
      if (inbox.md5 != topic.md5) {
        NODELET_WARN_THROTTLE(5.0, "dropping %s from %s on %s: another type than before",
                              topic.type.c_str(), peer.c_str(), name.c_str());
        count("dropped " + name + " (another type)");
        continue;
      }
      if (inbox.held.empty() && ros::WallTime::now() >= inbox.ready) {
        inbox.publisher.publish(msg);
      } else {
        inbox.held.push_back(msg);
      }
    }
  }

  void onFlushTimer(const ros::SteadyTimerEvent&) {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    const ros::WallTime now = ros::WallTime::now();
    for (auto& [name, inbox] : inboxes_) {
      if (now < inbox.ready) continue;
      for (const auto& msg : inbox.held) inbox.publisher.publish(msg);
      inbox.held.clear();
    }
  }

  /// Replaying, the budgets hold per mission second (MissionClock), so that a replay at any
  /// speed sends what the robots would have sent; live, the bridge keeps its monotonic clock.
  static transport::Bridge::Clock clock() {
    if (!ros::Time::isSimTime()) return {};
    // The bridge calls it under its own lock.
    return [reader = std::make_shared<MissionClockReader>()] { return reader->now(); };
  }

  void publishStats() {
    const ros::Time now = ros::Time::now();
    for (const auto& report : bridge_->reports()) {
      auto stats = boost::make_shared<LinkStats>();
      stats->header.stamp = now;
      stats->robot = settings_.frames.robot_name;
      stats->peer = report.peer;
      stats->connected = report.connected;
      stats->address = report.address;
      stats->bytes_sent = report.sent.bytes_sent;
      stats->bytes_received = report.received.bytes_received;
      stats->messages_sent = report.sent.messages_sent;
      stats->messages_received = report.received.messages_received;
      // Per second of the bridge's clock (mission time while replaying; the wall clock once
      // the replay has ended and the queues drain).
      const auto last = last_report_.find(report.peer);
      if (last != last_report_.end() && report.at_s > last->second.first) {
        stats->send_rate_bytes_per_s =
            static_cast<double>(report.sent.bytes_sent - last->second.second) /
            (report.at_s - last->second.first);
      }
      last_report_[report.peer] = {report.at_s, report.sent.bytes_sent};
      stats->budget_bytes_per_s = settings_.core.budget_bytes_per_s;
      stats->queued_control = static_cast<std::uint32_t>(report.queued_control);
      stats->queued_bulk = static_cast<std::uint32_t>(report.queued_bulk);
      stats->queued_control_bytes = report.queued_control_bytes;
      stats->queued_bulk_bytes = report.queued_bulk_bytes;
      stats->available_tokens_bytes = report.available_tokens_bytes;
      stats->total_budget_bytes_per_s = settings_.core.total_budget_bytes_per_s;
      for (const auto& [reason, n] : report.drops) {
        if (n == 0) continue;
        stats->drop_reasons.push_back(reason);
        stats->drop_counts.push_back(n);
      }
      if (report.silent_s >= 0 && now.toSec() >= report.silent_s) {
        stats->last_seen = now - ros::Duration(report.silent_s);
      }
      stats_pub_.publish(stats);
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

  ros_params::BridgeSettings settings_;
  ros::Publisher stats_pub_;
  std::vector<ros::Subscriber> subs_;
  ros::SteadyTimer flush_timer_;
  std::map<std::string, std::pair<double, std::uint64_t>> last_report_;  // at_s, bytes sent
  std::mutex inbox_mutex_;
  std::map<std::string, Inbox> inboxes_;
  // Last, so it is destroyed first: its thread calls onInbox.
  std::unique_ptr<transport::Bridge> bridge_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BridgeNodelet, nodelet::Nodelet)
