// Backend: keyframes + loop closures -> optimised trajectory, map -> odom and team transforms on
// tf, TeamTransform messages, teammates' keyframes as the team graph places them, pose
// uncertainty. Callbacks hand their input to the core's
// TeamGraphWorker, which optimises on its own thread at optimize_period_s and as soon as a loop
// closure arrives, so no solve ever holds a manager thread; it also decides where each loop
// closure goes (core::backend::routeOwnLoop / routeTeammateLoop).
#include <mutex>

#include <nav_msgs/Path.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/team/team_graph_worker.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::team::TeamGraph;
using Worker = core::team::TeamGraphWorker;

class BackendNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    Worker::Hooks hooks;
    hooks.run = [this](const auto& batch) { return measured("optimise", batch); };
    hooks.optimized = [this](const auto& snapshot, const TeamGraph& graph) {
      onOptimized(snapshot, graph);
    };
    hooks.refused = [this](Worker::Refusal why, const std::string& what) { onRefused(why, what); };
    worker_ = std::make_unique<Worker>(std::make_unique<TeamGraph>(robot(), settings_.core), hooks);
    advertise<nav_msgs::Path>(topics::kTrajectory, 1, /*latch=*/true);
    advertise<TeamTransform>(topics::kTeamTransforms, topics::kMessageQueueSize);
    advertise<TeamKeyframePoses>(topics::kTeamKeyframePoses, topics::kMessageQueueSize);
    advertise<KeyframeUncertainty>(topics::kKeyframeUncertainty, 1);
    advertise<visualization_msgs::MarkerArray>(topics::kLoopClosureMarkers, 1);
    // Inter-robot closures go to the teammates too: each robot verifies only the scans it
    // received, so without them a pair's two robots each see part of its closures.
    advertise<LoopClosure>(topics::kOutboxLoopClosures, topics::kLoopClosureQueueSize);
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &BackendNodelet::onKeyframe);
    subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize, &BackendNodelet::onPeerKeyframe);
    subscribe(topics::kLoopClosures, topics::kLoopClosureQueueSize, &BackendNodelet::onLoopClosure);
    subscribe(topics::kInboxLoopClosures, topics::kLoopClosureQueueSize,
              &BackendNodelet::onTeammateLoopClosure);
    createPeriodicTimer(settings_.core.optimize_period_s, [this] { worker_->tick(); });
  }

  const std::string& robot() const { return settings_.frames.robot_name; }

  void onKeyframe(const Keyframe& k) {
    worker_->add(Worker::OwnKeyframe{k.robot, k.id, conversions::toStamp(k.header.stamp),
                                     conversions::toPose(k.odom_pose)});
  }
  void onPeerKeyframe(const Keyframe& k) {
    worker_->add(Worker::PeerKeyframe{k.robot, k.id, conversions::toPose(k.odom_pose)});
  }

  void onLoopClosure(const LoopClosure::ConstPtr& msg) {
    if (const auto loop = toLoop(*msg, "loop_closures"); loop && worker_->addOwnLoop(*loop)) {
      publish(topics::kOutboxLoopClosures, msg);
    }
  }
  void onTeammateLoopClosure(const LoopClosure& msg) {
    if (const auto loop = toLoop(msg, "inbox/loop_closures")) worker_->addTeammateLoop(*loop);
  }
  std::optional<core::backend::LoopClosureData> toLoop(const LoopClosure& msg, const char* flow) {
    core::backend::LoopClosureData loop;
    if (conversions::toLoopClosure(msg, &loop)) return loop;
    drop(flow, "dropping a loop closure from %s: relative pose not finite", flow);
    return std::nullopt;
  }

  void onRefused(Worker::Refusal why, const std::string& what) {
    switch (why) {
      case Worker::Refusal::kDuplicateLoopClosure:
        return count("duplicate loop_closures");  // the teammate found it too
      case Worker::Refusal::kIgnoredLoopClosure:
        return count("ignored inbox/loop_closures (not with this robot)");
      case Worker::Refusal::kKeyframe:
        return drop("keyframes", "dropping %s", what.c_str());
      case Worker::Refusal::kPeerKeyframe:
        return drop("teammate_scans", "dropping teammate %s", what.c_str());
      case Worker::Refusal::kLoopClosure:
        return drop("loop_closures", "dropping %s", what.c_str());
      case Worker::Refusal::kTeammateLoopClosure:
        return drop("inbox/loop_closures", "dropping a teammate's %s", what.c_str());
    }
  }

  // On the worker's thread.
  void onOptimized(const core::team::BackendSnapshot& snapshot, const TeamGraph& graph) {
    if (snapshot.poses.empty()) return;
    const std::string& map_frame = settings_.frames.map_frame;
    const ros::Time stamp = conversions::toRosTime(snapshot.stamps.back());
    auto path = boost::make_shared<const nav_msgs::Path>(
        conversions::toPathMsg(snapshot.stamps, snapshot.poses, map_frame));
    publish(topics::kTrajectory, path);
    if (listened(topics::kLoopClosureMarkers)) {
      publish(topics::kLoopClosureMarkers,
              boost::make_shared<const visualization_msgs::MarkerArray>(
                  conversions::toLoopMarkersMsg(snapshot.loop_lines, map_frame, stamp)));
    }
    for (const auto& notice : snapshot.notices) warnPerKind(notice.kind, "%s", notice.text.c_str());
    for (const auto& estimate : snapshot.team) {
      publish(topics::kTeamTransforms,
              boost::make_shared<const TeamTransform>(
                  conversions::toTeamTransformMsg(estimate, map_frame, stamp)));
    }
    for (const auto& keyframes : snapshot.peer_keyframes) {
      publish(topics::kTeamKeyframePoses,
              boost::make_shared<const TeamKeyframePoses>(
                  conversions::toTeamKeyframePosesMsg(keyframes, map_frame, stamp)));
    }
    if (settings_.publish_tf) {
      // A re-optimisation without a new keyframe (a teammate's scan, a loop closure) must still
      // reach tf: tf2 ignores a transform repeated at a stamp it has, so the stamp moves on by 1
      // us.
      last_tf_stamp_ = std::max(stamp, last_tf_stamp_ + ros::Duration(1e-6));
      tf_broadcaster_.sendTransform(
          conversions::toTfMsgs(snapshot, map_frame, settings_.frames.odom_frame, last_tf_stamp_));
    }
    if (listened(topics::kKeyframeUncertainty)) {  // the Broker's u_k (CCIR)
      if (const auto variances =
              measured("uncertainty", [&] { return graph.positionVariances(snapshot.ids); })) {
        publish(topics::kKeyframeUncertainty,
                boost::make_shared<const KeyframeUncertainty>(conversions::toKeyframeUncertaintyMsg(
                    robot(), path->header, snapshot.ids, *variances)));
      }
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    last_ = {snapshot.solve_s, snapshot.intra_loops, snapshot.intra_loops_rejected,
             snapshot.inter_loops, snapshot.inter_loops_rejected};
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    status.addf("last optimisation s", "%.3f", last_.solve_s);
    status.add("intra-robot loops", last_.intra_loops);
    status.add("intra-robot loops rejected", last_.intra_loops_rejected);
    status.add("inter-robot loops in the graph", last_.inter_loops);
    status.add("inter-robot loops rejected", last_.inter_loops_rejected);
  }

  ros_params::BackendSettings settings_;
  std::mutex stats_mutex_;
  struct {
    double solve_s = 0.0;
    int intra_loops = 0, intra_loops_rejected = 0, inter_loops = 0, inter_loops_rejected = 0;
  } last_;  // the newest optimisation's, for diagnostics
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Time last_tf_stamp_;         // of the last transforms sent (worker thread only)
  std::unique_ptr<Worker> worker_;  // last: stopped first, while what it publishes with lives
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BackendNodelet, nodelet::Nodelet)
