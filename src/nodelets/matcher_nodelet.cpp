// Matcher: place recognition and loop-closure detection. Own keyframes -> features (word sets
// for teammates) and intra-robot loop closures; a teammate's word set -> correspondences (c_k of
// the local keyframes: CCIR's loop-closure potential); a teammate's scan -> inter-robot loop
// closures. The work is core::place_recognition::PlaceMatcher's; this converts and publishes.
#include <ros/package.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/place_recognition/place_matcher.h"
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
    try {
      matcher_ =
          std::make_unique<pr::PlaceMatcher>(settings_.core, pr::PlaceModel::load(model_dir));
    } catch (const std::exception& e) {
      return failConfiguration(std::string("model_dir: cannot load the place-recognition model: ") +
                               e.what());
    }
    NODELET_INFO("place recognition: %s, model %s (%zu words, vocabulary %s)",
                 pr::toString(settings_.core.method), model_dir.c_str(),
                 matcher_->model().vocabulary.size(), vocabularyHash().c_str());
    advertise<KeyframeFeatures>(topics::kFeatures, topics::kMessageQueueSize);
    advertise<Correspondences>(topics::kCorrespondences, topics::kMessageQueueSize);
    advertise<LoopClosure>(topics::kLoopClosures, topics::kLoopClosureQueueSize);
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &MatcherNodelet::onKeyframe);
    subscribe(topics::kInboxFeatures, topics::kMessageQueueSize, &MatcherNodelet::onPeerFeatures);
    subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize, &MatcherNodelet::onPeerScan);
  }

  const std::string& robot() const { return settings_.frames.robot_name; }
  const std::string& vocabularyHash() const { return matcher_->model().vocabulary.hash(); }

  /// Features, words and verification cloud of an own keyframe or a teammate's, or nullopt
  /// (dropped from `flow`).
  std::optional<pr::DescribedKeyframe> describe(const Keyframe& keyframe, const char* flow) {
    const auto pose = conversions::toPose(keyframe.odom_pose);
    pcl::PointCloud<pcl::PointXYZINormal> cloud;
    std::optional<std::string> error = conversions::toKeyframeCloud(keyframe.cloud, &cloud);
    if (!error && !pose) error = "odom_pose is not finite";
    if (error) {
      drop(flow, "dropping keyframe %lu of %s: %s", static_cast<unsigned long>(keyframe.id),
           keyframe.robot.c_str(), error->c_str());
      return std::nullopt;
    }
    const core::Stamp stamp = conversions::toStamp(keyframe.header.stamp);
    return measured("describe", [&] {
      return keyframe.robot == robot()
                 ? matcher_->describeOwn(keyframe.id, stamp, cloud, *pose)
                 : matcher_->describeTeammate(keyframe.id, stamp, cloud, *pose,
                                              keyframe.drawn_from_mixture);
    });
  }

  /// Publishes the best verified candidate, if any, as a loop closure. `query` is the keyframe
  /// the candidates were found for (own or a teammate's); the candidates' places are own
  /// keyframes, or teammates' kept scans when they name a robot.
  void publishBest(const std::vector<pr::MatchCandidate>& candidates,
                   const std::string& query_robot, core::KeyframeId query, const ros::Time& stamp,
                   const std::optional<core::Pose3>& query_odom_pose = {}) {
    verified_ += candidates.size();
    const pr::MatchCandidate* best = pr::bestAccepted(candidates);
    if (!best) return;
    auto loop = boost::make_shared<LoopClosure>(conversions::toLoopClosureMsg(
        matcher_->loopClosure(robot(), *best, query_robot, query, query_odom_pose)));
    loop->header.stamp = stamp;
    count(loop->robot_to == robot() ? "out loop_closures (own)" : "out loop_closures (teammates)");
    publish(topics::kLoopClosures, boost::shared_ptr<const LoopClosure>(loop));
  }

  void onKeyframe(const Keyframe& keyframe) {
    matcher_->addOwnTravel(keyframe.travelled_m);  // also when the keyframe is dropped
    auto described = describe(keyframe, "keyframes");
    if (!described) return;
    publish(topics::kFeatures,
            boost::make_shared<const KeyframeFeatures>(conversions::toKeyframeFeaturesMsg(
                keyframe.header, keyframe.robot, keyframe.id, vocabularyHash(), described->words,
                described->scan.features.descriptors.size())));
    // c_k of this keyframe with the teammates' keyframes whose word sets came before it.
    for (const auto& c : matcher_->teammateCorrespondences(described->words)) {
      publish(topics::kCorrespondences,
              boost::make_shared<const Correspondences>(conversions::toCorrespondencesMsg(
                  robot(), c.robot, c.keyframe, keyframe.header.stamp, {{keyframe.id, c.count}})));
    }
    // Teammates' scans kept so far may show this place too (they came before this robot did).
    const auto kept = measured("match", [&] { return matcher_->matchKeptScans(*described); });
    const auto candidates =
        measured("match", [&] { return matcher_->addOwn(std::move(*described)); });
    // Published once the keyframe is a place, so that each closure carries its pose.
    publishBest(kept, robot(), keyframe.id, keyframe.header.stamp);
    publishBest(candidates, robot(), keyframe.id, keyframe.header.stamp);
  }

  void onPeerFeatures(const KeyframeFeatures& features) {
    auto problem = matcher_->wordsProblem(features.vocabulary_hash, features.words);
    if (features.robot == robot()) problem = {"own", "from this robot itself (bridge loop?)"};
    if (problem) {
      return drop("features (" + problem->kind + ")", "refusing features of %s keyframe %lu: %s",
                  features.robot.c_str(), static_cast<unsigned long>(features.keyframe_id),
                  problem->text.c_str());
    }
    publish(topics::kCorrespondences,
            boost::make_shared<const Correspondences>(conversions::toCorrespondencesMsg(
                robot(), features.robot, features.keyframe_id, features.header.stamp,
                matcher_->correspondences(features.words))));
    matcher_->keepTeammateWords(features.robot, features.keyframe_id, features.words);
  }

  void onPeerScan(const Keyframe& scan) {
    if (scan.robot == robot()) {
      return drop("scans (own)",
                  "ignoring scans from this robot itself on the inbox (bridge loop?)");
    }
    auto described = describe(scan, "teammate_scans");
    if (!described) return;
    publishBest(measured("match", [&] { return matcher_->matchTeammate(*described); }), scan.robot,
                scan.id, scan.header.stamp, described->odom_pose);
    matcher_->keepTeammateScan(scan.robot, std::move(*described));
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    if (!matcher_) return;
    status.add("places", matcher_->places());
    status.add("teammate scans kept", matcher_->keptScans());
    status.add("candidates verified", verified_);
  }

  ros_params::MatcherSettings settings_;
  std::unique_ptr<pr::PlaceMatcher> matcher_;
  std::size_t verified_ = 0;  // candidates verified, for diagnostics
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MatcherNodelet, nodelet::Nodelet)
