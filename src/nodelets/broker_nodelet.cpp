// Broker: decides what this robot sends to its teammates. The fixed-rate baseline sends every
// n-th keyframe; CCIR offer/request routing arrives with the routing core. Both forward the
// local word sets to the outbox.
#include <mutex>
#include <sstream>

#include <dynamic_reconfigure/server.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/BrokerConfig.h"
#include "ccir_mapping/BrokerStats.h"
#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/ScanOffer.h"
#include "ccir_mapping/ScanReceipt.h"
#include "ccir_mapping/ScanRequest.h"
#include "ccir_mapping/core/routing/fixed_rate_selector.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

class BrokerNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    selector_ =
        std::make_unique<core::routing::FixedRateSelector>(settings_.core.fixed_rate_every_n);
    stats_.robot = settings_.frames.robot_name;

    stats_pub_ = nh.advertise<BrokerStats>(topics::kBrokerStats, topics::kLatestOnlyQueueSize);
    features_pub_ =
        nh.advertise<KeyframeFeatures>(topics::kOutboxFeatures, topics::kMessageQueueSize);
    offers_pub_ = nh.advertise<ScanOffer>(topics::kOutboxOffers, topics::kMessageQueueSize);
    requests_pub_ = nh.advertise<ScanRequest>(topics::kOutboxRequests, topics::kMessageQueueSize);
    receipts_pub_ = nh.advertise<ScanReceipt>(topics::kOutboxReceipts, topics::kMessageQueueSize);
    scans_pub_ = nh.advertise<Keyframe>(topics::kOutboxScans, topics::kKeyframeQueueSize);

    subs_.push_back(nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &BrokerNodelet::onKeyframe, this));
    subs_.push_back(nh.subscribe(topics::kFeatures, topics::kMessageQueueSize,
                                 &BrokerNodelet::onFeatures, this));
    subs_.push_back(nh.subscribe<Correspondences>(
        topics::kCorrespondences, topics::kMessageQueueSize,
        [this](const Correspondences::ConstPtr&) { count("in correspondences"); }));
    subs_.push_back(nh.subscribe<ScanOffer>(topics::kInboxOffers, topics::kMessageQueueSize,
                                            [this](const ScanOffer::ConstPtr&) {
                                              count("in inbox/offers");
                                              std::lock_guard<std::mutex> lock(mutex_);
                                              ++stats_.offers_received;
                                            }));
    subs_.push_back(nh.subscribe<ScanRequest>(topics::kInboxRequests, topics::kMessageQueueSize,
                                              [this](const ScanRequest::ConstPtr&) {
                                                count("in inbox/requests");
                                                std::lock_guard<std::mutex> lock(mutex_);
                                                ++stats_.requests_received;
                                              }));
    subs_.push_back(nh.subscribe<ScanReceipt>(topics::kInboxReceipts, topics::kMessageQueueSize,
                                              [this](const ScanReceipt::ConstPtr&) {
                                                count("in inbox/receipts");
                                                std::lock_guard<std::mutex> lock(mutex_);
                                                ++stats_.receipts_received;
                                              }));
    subs_.push_back(nh.subscribe<Keyframe>(
        topics::kInboxScans, topics::kKeyframeQueueSize, [this](const Keyframe::ConstPtr& scan) {
          count("in inbox/scans");
          std::lock_guard<std::mutex> lock(mutex_);
          ++stats_.scans_received;
          stats_.scan_bytes_received += ros::serialization::serializationLength(*scan);
        }));

    createPeriodicTimer(settings_.core.stats_period_s, [this] { publishStats(); });
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<BrokerConfig>>(
        reconfigure_mutex_, getPrivateNodeHandle());
    reconfigure_->setCallback([this](BrokerConfig& config, uint32_t) { onReconfigure(config); });
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    bool send = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.keyframes;
      if (settings_.core.mode == core::routing::RoutingMode::kFixedRate && selector_->select()) {
        send = true;
        ++stats_.scans_sent;
        stats_.scan_bytes_sent += ros::serialization::serializationLength(*keyframe);
      }
    }
    if (send) {
      count("out outbox/scans");
      scans_pub_.publish(keyframe);  // the same message, not a copy
    }
  }

  void onFeatures(const KeyframeFeatures::ConstPtr& features) {
    count("in features");
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.features_sent;
    }
    count("out outbox/features");
    features_pub_.publish(features);
  }

  void publishStats() {
    auto stats = boost::make_shared<BrokerStats>();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      *stats = stats_;
    }
    stats->header.stamp = ros::Time::now();
    stats->mode = core::routing::toString(settings_.core.mode);
    stats_pub_.publish(stats);
  }

  void onReconfigure(BrokerConfig& config) {
    std::lock_guard<std::mutex> lock(mutex_);
    core::routing::BrokerParams candidate = settings_.core;
    candidate.loop_closure_weight = config.loop_closure_weight;
    candidate.unknown_transform_factor = config.unknown_transform_factor;
    candidate.budget_bytes_per_s = config.budget_bytes_per_s;
    candidate.fixed_rate_every_n = config.fixed_rate_every_n;
    const auto errors = candidate.validate();
    if (!errors.empty()) {
      NODELET_ERROR("reconfigure rejected: %s", errors.front().c_str());
      config.loop_closure_weight = settings_.core.loop_closure_weight;
      config.unknown_transform_factor = settings_.core.unknown_transform_factor;
      config.budget_bytes_per_s = settings_.core.budget_bytes_per_s;
      config.fixed_rate_every_n = settings_.core.fixed_rate_every_n;
      return;
    }
    std::ostringstream changes;
    noteChange(changes, "loop_closure_weight", settings_.core.loop_closure_weight,
               candidate.loop_closure_weight);
    noteChange(changes, "unknown_transform_factor", settings_.core.unknown_transform_factor,
               candidate.unknown_transform_factor);
    noteChange(changes, "budget_bytes_per_s", settings_.core.budget_bytes_per_s,
               candidate.budget_bytes_per_s);
    noteChange(changes, "fixed_rate_every_n", settings_.core.fixed_rate_every_n,
               candidate.fixed_rate_every_n);
    if (!changes.str().empty()) NODELET_INFO("reconfigured:%s", changes.str().c_str());
    settings_.core = candidate;
    selector_->setEveryN(candidate.fixed_rate_every_n);
  }

  ros_params::BrokerSettings settings_;
  std::mutex mutex_;
  BrokerStats stats_;
  std::unique_ptr<core::routing::FixedRateSelector> selector_;
  ros::Publisher stats_pub_, features_pub_, offers_pub_, requests_pub_, receipts_pub_, scans_pub_;
  std::vector<ros::Subscriber> subs_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<BrokerConfig>> reconfigure_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BrokerNodelet, nodelet::Nodelet)
