// Backend: keyframes + loop closures -> optimised trajectory, map -> odom and team transforms on
// tf, TeamTransform messages, pose uncertainty. Callbacks hand their input to the core's
// TeamGraphWorker, which optimises on its own thread at optimize_period_s and as soon as a loop
// closure arrives, so no solve ever holds a manager thread.
#include <mutex>
#include <optional>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeUncertainty.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/backend/loop_closure.h"
#include "ccir_mapping/core/team/team_graph_worker.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::backend::LoopRoute;
using core::team::TeamGraph;
using Worker = core::team::TeamGraphWorker;

class BackendNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    Worker::Hooks hooks;
    hooks.run = [this](const auto& batch) { return measured("optimise", batch); };
    hooks.optimized = [this](const auto& snapshot, const TeamGraph& graph) {
      publish(snapshot, graph);
    };
    hooks.refused = [this](Worker::Refusal why, const std::string& what) { onRefused(why, what); };
    worker_ = std::make_unique<Worker>(
        std::make_unique<TeamGraph>(settings_.frames.robot_name, settings_.core), hooks);
    ros::NodeHandle& nh = getNodeHandle();
    trajectory_pub_ = nh.advertise<nav_msgs::Path>(topics::kTrajectory, 1, /*latch=*/true);
    team_pub_ = nh.advertise<TeamTransform>(topics::kTeamTransforms, topics::kMessageQueueSize);
    uncertainty_pub_ = nh.advertise<KeyframeUncertainty>(topics::kKeyframeUncertainty, 1);
    loop_marker_pub_ =
        nh.advertise<visualization_msgs::MarkerArray>(topics::kLoopClosureMarkers, 1);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &BackendNodelet::onKeyframe, this);
    peer_sub_ = nh.subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize,
                             &BackendNodelet::onPeerKeyframe, this);
    loop_sub_ = nh.subscribe(topics::kLoopClosures, topics::kLoopClosureQueueSize,
                             &BackendNodelet::onLoopClosure, this);
    // Inter-robot closures go to the teammates too: each robot verifies only the scans it
    // received, so without them a pair's two robots each see part of its closures.
    outbox_loop_pub_ =
        nh.advertise<LoopClosure>(topics::kOutboxLoopClosures, topics::kLoopClosureQueueSize);
    inbox_loop_sub_ = nh.subscribe(topics::kInboxLoopClosures, topics::kLoopClosureQueueSize,
                                   &BackendNodelet::onTeammateLoopClosure, this);
    createPeriodicTimer(settings_.core.optimize_period_s, [this] { worker_->tick(); });
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    const auto pose = conversions::toPose(keyframe->odom_pose);
    if (!pose || keyframe->robot != settings_.frames.robot_name) {
      NODELET_WARN_THROTTLE(5.0, "dropping keyframe %lu of '%s': %s",
                            static_cast<unsigned long>(keyframe->id), keyframe->robot.c_str(),
                            pose ? "not this robot's" : "its pose is not finite");
      count("dropped keyframes");
      return;
    }
    worker_->add(
        Worker::OwnKeyframe{keyframe->id, conversions::toStamp(keyframe->header.stamp), *pose});
  }

  void onPeerKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in teammate_scans");
    const auto pose = conversions::toPose(keyframe->odom_pose);
    if (!pose || keyframe->robot == settings_.frames.robot_name || keyframe->robot.empty()) {
      NODELET_WARN_THROTTLE(5.0, "dropping a teammate's keyframe from '%s': %s",
                            keyframe->robot.c_str(),
                            pose ? "not a teammate's" : "its pose is not finite");
      count("dropped teammate_scans");
      return;
    }
    worker_->add(Worker::PeerKeyframe{keyframe->robot, keyframe->id, *pose});
  }

  /// The closure in the core's terms, or nullopt (warned, counted in `flow`).
  std::optional<core::backend::LoopClosureData> toLoop(const LoopClosure& msg, const char* flow) {
    core::backend::LoopClosureData loop;
    std::optional<std::string> problem = "relative pose not finite";
    if (conversions::toLoopClosure(msg, &loop)) problem = core::backend::loopClosureProblem(loop);
    if (!problem) return loop;
    NODELET_WARN_THROTTLE(5.0, "dropping loop closure %s/%lu -> %s/%lu from %s: %s",
                          msg.robot_from.c_str(), static_cast<unsigned long>(msg.keyframe_from),
                          msg.robot_to.c_str(), static_cast<unsigned long>(msg.keyframe_to), flow,
                          problem->c_str());
    count(std::string("dropped ") + flow);
    return std::nullopt;
  }

  void onLoopClosure(const LoopClosure::ConstPtr& msg) {
    count("in loop_closures");
    const auto loop = toLoop(*msg, "loop_closures");
    if (!loop) return;
    switch (core::backend::routeOwnLoop(settings_.frames.robot_name, *loop)) {
      case LoopRoute::kUseAndForward:
        count("out outbox/loop_closures");
        outbox_loop_pub_.publish(msg);
        [[fallthrough]];
      case LoopRoute::kUse:
        worker_->add(*loop);
        return;
      default:
        NODELET_WARN_THROTTLE(5.0, "dropping loop closure %s -> %s: it does not involve this robot",
                              msg->robot_from.c_str(), msg->robot_to.c_str());
        count("dropped loop_closures");
    }
  }

  /// A closure a teammate found (its keyframe "from", with its odometry pose).
  void onTeammateLoopClosure(const LoopClosure::ConstPtr& msg) {
    count("in inbox/loop_closures");
    const auto loop = toLoop(*msg, "inbox/loop_closures");
    if (!loop) return;
    switch (core::backend::routeTeammateLoop(settings_.frames.robot_name, *loop)) {
      case LoopRoute::kUse:
        worker_->add(
            Worker::PeerKeyframe{loop->robot_from, loop->keyframe_from, *loop->odom_pose_from});
        worker_->add(*loop);
        return;
      case LoopRoute::kIgnore:
        count("ignored inbox/loop_closures (not with this robot)");
        return;
      default:
        NODELET_WARN_THROTTLE(5.0,
                              "dropping a teammate's loop closure from '%s': no odom_pose_from",
                              msg->robot_from.c_str());
        count("dropped inbox/loop_closures");
    }
  }

  void onRefused(Worker::Refusal why, const std::string& what) {
    switch (why) {
      case Worker::Refusal::kDuplicateLoopClosure:
        count("duplicate loop_closures");  // the teammate found it too
        return;
      case Worker::Refusal::kKeyframe:
        NODELET_WARN_THROTTLE(5.0, "%s ignored: ids must increase", what.c_str());
        count("dropped keyframes");
        return;
      case Worker::Refusal::kPeerKeyframe:
        NODELET_WARN_THROTTLE(5.0, "teammate %s rejected by the graph", what.c_str());
        count("dropped teammate_scans");
        return;
      case Worker::Refusal::kLoopClosure:
        NODELET_WARN_THROTTLE(5.0, "%s rejected by the graph", what.c_str());
        count("dropped loop_closures");
    }
  }

  // On the worker's thread.
  void publish(const core::team::BackendSnapshot& snapshot, const TeamGraph& graph) {
    if (snapshot.poses.empty()) return;
    const std::string& map_frame = settings_.frames.map_frame;
    const ros::Time stamp = conversions::toRosTime(snapshot.stamps.back());
    auto path = boost::make_shared<nav_msgs::Path>(
        conversions::toPathMsg(snapshot.stamps, snapshot.poses, map_frame));
    count("out trajectory");
    trajectory_pub_.publish(path);
    if (loop_marker_pub_.getNumSubscribers() > 0) {
      loop_marker_pub_.publish(boost::make_shared<visualization_msgs::MarkerArray>(
          conversions::toLoopMarkersMsg(snapshot.loop_lines, map_frame, stamp)));
    }

    std::vector<geometry_msgs::TransformStamped> transforms;
    // A re-optimisation without a new keyframe (a teammate's scan, a loop closure) must still
    // reach tf: tf2 ignores a transform repeated at a stamp it has, so the stamp moves on by 1 us.
    const ros::Time tf_stamp = std::max(stamp, last_tf_stamp_ + ros::Duration(1e-6));
    if (settings_.publish_tf) {
      transforms.push_back(conversions::toTransformStampedMsg(
          tf_stamp, map_frame, settings_.frames.odom_frame,
          snapshot.poses.back() * snapshot.latest_odom_pose.inverse()));
    }
    for (const auto& estimate : snapshot.team) {
      const auto& a = estimate.alignment;
      auto msg = boost::make_shared<TeamTransform>(
          conversions::toTeamTransformMsg(estimate, map_frame, stamp));
      count("out team_transforms");
      team_pub_.publish(msg);
      if (a.found && settings_.publish_tf) {
        transforms.push_back(conversions::toTransformStampedMsg(tf_stamp, map_frame,
                                                                msg->child_frame_id, a.transform));
      }
      if (!a.found)
        NODELET_DEBUG("no transform to %s yet: %s", estimate.peer.c_str(), a.reason.c_str());
    }
    if (!transforms.empty()) {
      tf_broadcaster_.sendTransform(transforms);
      last_tf_stamp_ = tf_stamp;
    }

    if (uncertainty_pub_.getNumSubscribers() > 0) {  // the Broker's u_k (CCIR)
      const auto variances =
          measured("uncertainty", [&] { return graph.positionVariances(snapshot.ids); });
      if (variances) {
        auto msg = boost::make_shared<KeyframeUncertainty>();
        msg->header = path->header;
        msg->robot = settings_.frames.robot_name;
        msg->keyframe_ids.assign(snapshot.ids.begin(), snapshot.ids.end());
        msg->position_variance_m2 = *variances;
        count("out keyframe_uncertainty");
        uncertainty_pub_.publish(msg);
      }
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    last_solve_s_ = snapshot.solve_s;
    intra_loops_ = snapshot.intra_loops;
    intra_rejected_ = snapshot.intra_loops_rejected;
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    status.addf("last optimisation s", "%.3f", last_solve_s_);
    status.add("intra-robot loops", intra_loops_);
    status.add("intra-robot loops rejected", intra_rejected_);
  }

  ros_params::BackendSettings settings_;
  std::mutex stats_mutex_;
  double last_solve_s_ = 0.0;
  int intra_loops_ = 0;
  int intra_rejected_ = 0;
  ros::Publisher trajectory_pub_;
  ros::Publisher loop_marker_pub_;
  ros::Publisher team_pub_;
  ros::Publisher uncertainty_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber peer_sub_;
  ros::Subscriber loop_sub_;
  ros::Publisher outbox_loop_pub_;
  ros::Subscriber inbox_loop_sub_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Time last_tf_stamp_;         // of the last transforms sent (worker thread only)
  std::unique_ptr<Worker> worker_;  // last: stopped first, while what it publishes with lives
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BackendNodelet, nodelet::Nodelet)
