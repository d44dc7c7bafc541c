// Matcher: place recognition and loop-closure detection. Own keyframes -> features (word sets
// for teammates) and intra-robot loop closures; a teammate's word set -> correspondences (c_k of
// the local keyframes: CCIR's loop-closure potential); a teammate's scan -> inter-robot loop
// closures. The work and every decision are core::place_recognition::MatcherStage's; this
// converts and publishes.
#include <ros/package.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/place_recognition/matcher_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

namespace pr = core::place_recognition;

class MatcherNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    const std::string model_dir = settings_.core.model_dir.empty()
                                      ? ros::package::getPath("ccir_mapping") + "/models/sim_mine"
                                      : settings_.core.model_dir;
    pr::MatcherStage::Hooks hooks;
    hooks.run = [this](const char* stage, const auto& work) { measured(stage, work); };
    try {
      stage_ = std::make_unique<pr::MatcherStage>(robot(), settings_.core,
                                                  pr::PlaceModel::load(model_dir), hooks);
    } catch (const std::exception& e) {
      return failConfiguration(std::string("model_dir: cannot load the place-recognition model: ") +
                               e.what());
    }
    NODELET_INFO("place recognition: %s, model %s (%zu words, vocabulary %s)",
                 pr::toString(settings_.core.method), model_dir.c_str(),
                 stage_->matcher().model().vocabulary.size(), stage_->vocabularyHash().c_str());
    advertise<KeyframeFeatures>(topics::kFeatures, topics::kMessageQueueSize);
    advertise<Correspondences>(topics::kCorrespondences, topics::kMessageQueueSize);
    advertise<LoopClosure>(topics::kLoopClosures, topics::kLoopClosureQueueSize);
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &MatcherNodelet::onKeyframe);
    subscribe(topics::kInboxFeatures, topics::kMessageQueueSize, &MatcherNodelet::onPeerFeatures);
    subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize, &MatcherNodelet::onPeerScan);
    subscribe(topics::kInboxLoopClosures, topics::kLoopClosureQueueSize,
              &MatcherNodelet::onPeerLoopClosure);
  }

  const std::string& robot() const { return settings_.frames.robot_name; }

  /// The keyframe's cloud and odometry pose, or nullopt (dropped from `flow`).
  std::optional<std::pair<pr::MatcherStage::Cloud, core::Pose3>> read(const Keyframe& keyframe,
                                                                      const char* flow) {
    std::pair<pr::MatcherStage::Cloud, core::Pose3> scan;
    std::optional<std::string> error = conversions::toKeyframeCloud(keyframe.cloud, &scan.first);
    const auto pose = conversions::toPose(keyframe.odom_pose);
    if (!error && !pose) error = "odom_pose is not finite";
    if (!error) {
      scan.second = *pose;
      return scan;
    }
    drop(flow, "dropping keyframe %lu of %s: %s", static_cast<unsigned long>(keyframe.id),
         keyframe.robot.c_str(), error->c_str());
    return std::nullopt;
  }

  /// Publishes what a step of the stage returned (header: of the message it came from).
  void publish(const pr::MatcherStage::Output& out, const std_msgs::Header& header) {
    for (const auto& refusal : out.refused) drop(refusal.kind, "%s", refusal.text.c_str());
    if (out.features) {
      PipelineNodelet::publish(topics::kFeatures,
                               boost::make_shared<const KeyframeFeatures>(
                                   conversions::toKeyframeFeaturesMsg(header, *out.features)));
    }
    for (const auto& c : out.correspondences) {
      PipelineNodelet::publish(topics::kCorrespondences,
                               boost::make_shared<const Correspondences>(
                                   conversions::toCorrespondencesMsg(robot(), c, header.stamp)));
    }
    for (const auto& loop : out.loop_closures) {
      auto msg = boost::make_shared<LoopClosure>(conversions::toLoopClosureMsg(loop));
      msg->header.stamp = header.stamp;
      count(loop.robot_to == robot() ? "out loop_closures (own)" : "out loop_closures (teammates)");
      PipelineNodelet::publish(topics::kLoopClosures, boost::shared_ptr<const LoopClosure>(msg));
    }
    verified_ += out.verified;
  }

  void onKeyframe(const Keyframe& keyframe) {
    stage_->addOwnTravel(keyframe.travelled_m);  // also when the keyframe is dropped
    const auto scan = read(keyframe, "keyframes");
    if (!scan) return;
    pr::DescribedKeyframe described;
    publish(stage_->describeOwn(keyframe.id, conversions::toStamp(keyframe.header.stamp),
                                scan->first, scan->second, &described),
            keyframe.header);
    publish(stage_->matchOwn(std::move(described)), keyframe.header);
  }

  void onPeerFeatures(const KeyframeFeatures& features) {
    publish(stage_->onTeammateWords(conversions::toKeyframeWords(features)), features.header);
  }

  void onPeerScan(const Keyframe& keyframe) {
    const auto scan = read(keyframe, "teammate_scans");
    if (!scan) return;
    publish(stage_->onTeammateScan(keyframe.robot, keyframe.id,
                                   conversions::toStamp(keyframe.header.stamp), scan->first,
                                   scan->second, keyframe.drawn_from_mixture),
            keyframe.header);
  }

  void onPeerLoopClosure(const LoopClosure& msg) {
    core::pose_graph::LoopClosureData loop;  // a malformed one: the Backend reports it
    if (conversions::toLoopClosure(msg, &loop)) stage_->onTeammateClosure(loop);
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    if (!stage_) return;
    status.add("places", stage_->matcher().places());
    status.add("teammate scans kept", stage_->matcher().keptScans());
    status.add("candidates verified", verified_);
    status.add("candidates queued", stage_->matcher().queued());
    status.add("candidates expired unverified", stage_->matcher().expired());
  }

  ros_params::MatcherSettings settings_;
  std::unique_ptr<pr::MatcherStage> stage_;
  std::size_t verified_ = 0;  // candidates verified, for diagnostics
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MatcherNodelet, nodelet::Nodelet)
