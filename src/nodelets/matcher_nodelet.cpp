// Matcher: keyframes -> features (word sets), correspondences and loop closures. Until the
// place-recognition core lands it publishes an empty word set per keyframe and counts what
// teammates send.
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

class MatcherNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    features_pub_ = nh.advertise<KeyframeFeatures>(topics::kFeatures, topics::kMessageQueueSize);
    correspondences_pub_ =
        nh.advertise<Correspondences>(topics::kCorrespondences, topics::kMessageQueueSize);
    loop_pub_ = nh.advertise<LoopClosure>(topics::kLoopClosures, topics::kMessageQueueSize);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &MatcherNodelet::onKeyframe, this);
    inbox_features_sub_ = nh.subscribe(topics::kInboxFeatures, topics::kMessageQueueSize,
                                       &MatcherNodelet::onPeerFeatures, this);
    inbox_scans_sub_ = nh.subscribe(topics::kInboxScans, topics::kKeyframeQueueSize,
                                    &MatcherNodelet::onPeerScan, this);
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    auto features = boost::make_shared<KeyframeFeatures>();
    features->header = keyframe->header;
    features->robot = keyframe->robot;
    features->keyframe_id = keyframe->id;
    count("out features");
    features_pub_.publish(features);
  }

  bool fromTeammate(const std::string& robot, const char* what) {
    if (robot != settings_.frames.robot_name) return true;
    NODELET_WARN_THROTTLE(5.0, "ignoring %s from this robot itself on the inbox (bridge loop?)",
                          what);
    return false;
  }

  void onPeerFeatures(const KeyframeFeatures::ConstPtr& features) {
    if (fromTeammate(features->robot, "features")) count("in inbox/features");
  }

  void onPeerScan(const Keyframe::ConstPtr& scan) {
    if (fromTeammate(scan->robot, "a scan")) count("in inbox/scans", scan->cloud.data.size());
  }

  ros_params::MatcherSettings settings_;
  ros::Publisher features_pub_;
  ros::Publisher correspondences_pub_;
  ros::Publisher loop_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber inbox_features_sub_;
  ros::Subscriber inbox_scans_sub_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MatcherNodelet, nodelet::Nodelet)
