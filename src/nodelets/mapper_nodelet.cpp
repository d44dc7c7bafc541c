// Mapper: keyframes and received scans -> the distributed occupancy map. Until the information
// core lands it counts what it would integrate.
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

class MapperNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &MapperNodelet::onKeyframe, this);
    inbox_scans_sub_ = nh.subscribe(topics::kInboxScans, topics::kKeyframeQueueSize,
                                    &MapperNodelet::onPeerScan, this);
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes", keyframe->cloud.data.size());
  }

  void onPeerScan(const Keyframe::ConstPtr& scan) {
    count("in inbox/scans", scan->cloud.data.size());
  }

  ros_params::MapperSettings settings_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber inbox_scans_sub_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MapperNodelet, nodelet::Nodelet)
