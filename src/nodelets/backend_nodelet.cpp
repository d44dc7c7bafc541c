// Backend: keyframes + loop closures -> optimised trajectory, map -> odom and team transforms on
// tf, TeamTransform, teammates' keyframes as the team graph places them, pose uncertainty.
// Callbacks hand their input to core::backend::BackendStage, which optimises on its own thread
// (at optimize_period_s: keyframes placed, a solve when a loop closure arrived) and routes each
// loop closure.
#include <nav_msgs/Path.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/backend/backend_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using Stage = core::backend::BackendStage;
using Loop = core::pose_graph::LoopClosureData;

class BackendNodelet final : public PipelineNodelet {
 public:
  ~BackendNodelet() override { saveAtShutdown(); }

 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    Stage::Hooks hooks;
    hooks.run = [this](const char* stage, const auto& work) { measured(stage, work); };
    hooks.optimized = [this](const Stage::Output& out) { onOptimized(out); };
    hooks.refused = [this](const Stage::Refusal& r) {
      if (!r.dropped) return count(r.notice.kind);
      drop(r.notice.kind, "%s", r.notice.text.c_str());
    };
    hooks.unjournaled = [this](const std::string& why) {
      drop("journal", "an input was not journaled (a restart cannot resume it): %s", why.c_str());
    };
    hooks.wants_uncertainty = [this] { return listened(topics::kKeyframeUncertainty); };
    stage_ = std::make_unique<Stage>(robot(), settings_.core, hooks);
    const auto& saving = settings_.save;
    if (!openJournal(saving.resume, [&] { stage_->openJournal(saving.dir, saving.resume); })) {
      return stage_.reset();
    }
    advertise<nav_msgs::Path>(topics::kTrajectory, 1, /*latch=*/true);
    advertise<TeamTransform>(topics::kTeamTransforms, topics::kMessageQueueSize);
    advertise<TeamKeyframePoses>(topics::kTeamKeyframePoses, topics::kMessageQueueSize);
    advertise<KeyframeUncertainty>(topics::kKeyframeUncertainty, 1);
    advertise<visualization_msgs::MarkerArray>(topics::kLoopClosureMarkers, 1);
    // Inter-robot closures go to the teammates too: each robot verifies only the scans it
    // received, so without them a pair's two robots each see part of its closures.
    advertise<LoopClosure>(topics::kOutboxLoopClosures, topics::kLoopClosureQueueSize);
    // The previous run's inputs before any new one (own keyframe ids must increase).
    if (const std::size_t resumed = stage_->keepJournal())
      NODELET_INFO("resumed the team graph from %zu inputs in save_dir", resumed);
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &BackendNodelet::onKeyframe);
    subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize, &BackendNodelet::onPeerKeyframe);
    subscribe(topics::kLoopClosures, topics::kLoopClosureQueueSize, &BackendNodelet::onLoopClosure);
    subscribe(topics::kInboxLoopClosures, topics::kLoopClosureQueueSize,
              &BackendNodelet::onTeammateLoopClosure);
    createPeriodicTimer(settings_.core.optimize_period_s, [this] { stage_->tick(); });
    // After the optimisation under way, if any.
    serveSaving("save_team_graph", settings_.save, [this] { return stage_->save(saveDir()); });
  }

  const std::string& robot() const { return settings_.frames.robot_name; }
  const std::string& saveDir() const { return settings_.save.dir; }

  void onKeyframe(const Keyframe& k) {
    stage_->add(Stage::OwnKeyframe{k.robot, k.id, conversions::toStamp(k.header.stamp),
                                   conversions::toPose(k.odom_pose)});
  }
  void onPeerKeyframe(const Keyframe& k) {
    stage_->add(Stage::PeerKeyframe{k.robot, k.id, conversions::toPose(k.odom_pose)});
  }

  void onLoopClosure(const LoopClosure::ConstPtr& msg) {
    if (const auto loop = toLoop(*msg, "loop_closures"); loop && stage_->addOwnLoop(*loop)) {
      publish(topics::kOutboxLoopClosures, msg);
    }
  }
  void onTeammateLoopClosure(const LoopClosure& msg) {
    if (const auto loop = toLoop(msg, "inbox/loop_closures")) stage_->addTeammateLoop(*loop);
  }
  std::optional<Loop> toLoop(const LoopClosure& msg, const char* flow) {
    Loop loop;
    if (conversions::toLoopClosure(msg, &loop)) return loop;
    drop(flow, "dropping a loop closure from %s: relative pose not finite", flow);
    return std::nullopt;
  }

  // On the worker's thread.
  void onOptimized(const Stage::Output& out) {
    const core::backend::BackendSnapshot& snapshot = out.snapshot;
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
      // A re-optimisation without a new keyframe must reach tf too: tf2 ignores a transform
      // repeated at a stamp it has, so the stamp moves on by 1 us.
      last_tf_stamp_ = std::max(stamp, last_tf_stamp_ + ros::Duration(1e-6));
      tf_broadcaster_.sendTransform(
          conversions::toTfMsgs(snapshot, map_frame, settings_.frames.odom_frame, last_tf_stamp_));
    }
    if (out.uncertainty) {  // the Broker's u_k (CCIR)
      publish(topics::kKeyframeUncertainty,
              boost::make_shared<const KeyframeUncertainty>(conversions::toKeyframeUncertaintyMsg(
                  robot(), path->header, snapshot.ids, *out.uncertainty)));
    }
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    if (!stage_) return;
    const auto latest = stage_->latest();
    status.addf("last optimisation s", "%.3f", latest.solve_s);
    status.add("intra-robot loops", latest.loops.intra);
    status.add("intra-robot loops rejected", latest.loops.intra_rejected);
    status.add("inter-robot loops in the graph", latest.loops.inter);
    status.add("inter-robot loops rejected", latest.loops.inter_rejected);
    status.add("windowed solves", latest.windowed_solves);
    status.add("full solves", latest.full_solves);
    status.addf("last full solve's correction m", "%.3f", latest.full_correction_m);
  }

  ros_params::BackendSettings settings_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Time last_tf_stamp_;       // of the last transforms sent (worker thread only)
  std::unique_ptr<Stage> stage_;  // stopped while what it publishes with lives
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BackendNodelet, nodelet::Nodelet)
