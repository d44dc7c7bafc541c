// Bridge: carries the outbox topics to teammates' ROS masters. This skeleton subscribes to
// every configured outbox topic as raw bytes (any message type), counts what it would send and
// reports each peer link; the TCP transport with its byte budget arrives with the transport core.
#include <mutex>

#include <topic_tools/shape_shifter.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

class BridgeNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    stats_pub_ = nh.advertise<LinkStats>(topics::kLinkStats, topics::kMessageQueueSize);
    for (const auto& forwarded : settings_.core.topics) {
      const std::string topic = forwarded.topic;
      subs_.push_back(nh.subscribe<topic_tools::ShapeShifter>(
          topic, topics::kMessageQueueSize,
          [this, topic](const topic_tools::ShapeShifter::ConstPtr& msg) {
            onOutbox(topic, *msg);
          }));
    }
    if (settings_.core.peers.empty()) {
      NODELET_INFO("no peers configured: outbox traffic is counted, not sent");
    }
    stats_timer_ = nh.createSteadyTimer(ros::WallDuration(settings_.core.stats_period_s),
                                        &BridgeNodelet::onStatsTimer, this);
  }

  void onOutbox(const std::string& topic, const topic_tools::ShapeShifter& msg) {
    count("in " + topic, msg.size());
    // No transport yet: every message is dropped for every peer.
    std::lock_guard<std::mutex> lock(mutex_);
    ++not_sent_;
  }

  void onStatsTimer(const ros::SteadyTimerEvent&) {
    std::uint64_t not_sent = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      not_sent = not_sent_;
    }
    for (const auto& peer : settings_.core.peers) {
      auto stats = boost::make_shared<LinkStats>();
      stats->header.stamp = ros::Time::now();
      stats->robot = settings_.frames.robot_name;
      stats->peer = peer.name;
      stats->address = peer.host + ":" + std::to_string(peer.port);
      stats->budget_bytes_per_s = settings_.core.budget_bytes_per_s;
      stats->drop_reasons = {"not_connected"};
      stats->drop_counts = {not_sent};
      stats_pub_.publish(stats);
    }
  }

  ros_params::BridgeSettings settings_;
  std::mutex mutex_;
  std::uint64_t not_sent_ = 0;  // outbox messages no peer received
  ros::Publisher stats_pub_;
  std::vector<ros::Subscriber> subs_;
  ros::SteadyTimer stats_timer_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BridgeNodelet, nodelet::Nodelet)
