// Backend: keyframes + loop closures -> trajectory, team transforms, map -> odom on tf. Until
// the pose-graph core lands the trajectory is the odometry of the keyframes and map = odom.
#include <mutex>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <tf2_ros/transform_broadcaster.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

class BackendNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    trajectory_pub_ = nh.advertise<nav_msgs::Path>(topics::kTrajectory, 1, /*latch=*/true);
    team_pub_ = nh.advertise<TeamTransform>(topics::kTeamTransforms, topics::kMessageQueueSize);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &BackendNodelet::onKeyframe, this);
    loop_sub_ = nh.subscribe(topics::kLoopClosures, topics::kMessageQueueSize,
                             &BackendNodelet::onLoopClosure, this);
    timer_ = nh.createSteadyTimer(ros::WallDuration(settings_.core.optimize_period_s),
                                  &BackendNodelet::onTimer, this);
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    geometry_msgs::PoseStamped pose;
    pose.header.stamp = keyframe->header.stamp;
    pose.header.frame_id = settings_.frames.map_frame;
    pose.pose = keyframe->odom_pose;
    std::lock_guard<std::mutex> lock(mutex_);
    poses_.push_back(pose);
    latest_stamp_ = keyframe->header.stamp;
    dirty_ = true;
  }

  void onLoopClosure(const LoopClosure::ConstPtr&) { count("in loop_closures"); }

  void onTimer(const ros::SteadyTimerEvent&) {
    boost::shared_ptr<nav_msgs::Path> path;
    ros::Time stamp;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!dirty_) return;
      dirty_ = false;
      path = boost::make_shared<nav_msgs::Path>();
      path->header.frame_id = settings_.frames.map_frame;
      path->header.stamp = latest_stamp_;
      path->poses = poses_;
      stamp = latest_stamp_;
    }
    count("out trajectory");
    trajectory_pub_.publish(path);
    if (settings_.publish_tf) {
      geometry_msgs::TransformStamped map_to_odom;
      map_to_odom.header.stamp = stamp;
      map_to_odom.header.frame_id = settings_.frames.map_frame;
      map_to_odom.child_frame_id = settings_.frames.odom_frame;
      map_to_odom.transform.rotation.w = 1.0;
      tf_broadcaster_.sendTransform(map_to_odom);
    }
  }

  ros_params::BackendSettings settings_;
  std::mutex mutex_;
  std::vector<geometry_msgs::PoseStamped> poses_;
  ros::Time latest_stamp_;
  bool dirty_ = false;
  ros::Publisher trajectory_pub_;
  ros::Publisher team_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber loop_sub_;
  ros::SteadyTimer timer_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BackendNodelet, nodelet::Nodelet)
