// Matcher: place recognition and loop-closure detection. Own keyframes -> features (word sets
// for teammates) and intra-robot loop closures; a teammate's word set -> correspondences (c_k of
// the local keyframes: CCIR's loop-closure potential); a teammate's scan -> inter-robot loop
// closures. The work is PlaceMatcher's; this converts messages and publishes.
#include <algorithm>
#include <atomic>
#include <memory>

#include <ros/package.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/LoopClosure.h"
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
      failConfiguration(std::string("model_dir: cannot load the place-recognition model: ") +
                        e.what());
      return;
    }
    NODELET_INFO("place recognition: %s, model %s (%zu words, vocabulary %s)",
                 pr::toString(settings_.core.method), model_dir.c_str(),
                 matcher_->model().vocabulary.size(), vocabularyHash().c_str());
    ros::NodeHandle& nh = getNodeHandle();
    features_pub_ = nh.advertise<KeyframeFeatures>(topics::kFeatures, topics::kMessageQueueSize);
    correspondences_pub_ =
        nh.advertise<Correspondences>(topics::kCorrespondences, topics::kMessageQueueSize);
    loop_pub_ = nh.advertise<LoopClosure>(topics::kLoopClosures, topics::kLoopClosureQueueSize);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &MatcherNodelet::onKeyframe, this);
    inbox_features_sub_ = nh.subscribe(topics::kInboxFeatures, topics::kMessageQueueSize,
                                       &MatcherNodelet::onPeerFeatures, this);
    teammate_scans_sub_ = nh.subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize,
                                       &MatcherNodelet::onPeerScan, this);
  }

  const std::string& vocabularyHash() const { return matcher_->model().vocabulary.hash(); }

  /// Features, words and verification cloud of a keyframe, or nullopt (warned, counted).
  std::optional<pr::DescribedKeyframe> describe(const Keyframe& keyframe, const char* flow) {
    const auto pose = conversions::toPose(keyframe.odom_pose);
    pcl::PointCloud<pcl::PointXYZINormal> cloud;
    std::optional<std::string> error = conversions::toKeyframeCloud(keyframe.cloud, &cloud);
    if (!error && !pose) error = "odom_pose is not finite";
    if (error) {
      NODELET_WARN_THROTTLE(5.0, "dropping %s keyframe %lu of %s: %s", flow,
                            static_cast<unsigned long>(keyframe.id), keyframe.robot.c_str(),
                            error->c_str());
      count(std::string("dropped ") + flow);
      return std::nullopt;
    }
    auto described = measured("describe", [&] {
      return matcher_->describe(keyframe.id, conversions::toStamp(keyframe.header.stamp), cloud,
                                core::upInFrame(*pose));
    });
    described.odom_pose = *pose;
    return described;
  }

  /// Publishes the best verified candidate, if any, as a loop closure. `query` is the keyframe
  /// the candidates were found for (own or a teammate's); the candidates' places are own
  /// keyframes, or teammates' kept scans when they name a robot.
  void publishBest(const std::vector<pr::MatchCandidate>& candidates,
                   const std::string& query_robot, core::KeyframeId query, const ros::Time& stamp) {
    verified_ += candidates.size();
    const pr::MatchCandidate* best = pr::bestAccepted(candidates);
    if (!best) return;
    const std::string& self = settings_.frames.robot_name;
    auto loop = boost::make_shared<LoopClosure>(
        conversions::toLoopClosureMsg(matcher_->loopClosure(self, *best, query_robot, query)));
    loop->header.stamp = stamp;
    loop->match_score = best->score;
    loop->fitness_m2 = best->verification.fitness_m2;
    loop->inliers = static_cast<std::uint32_t>(best->verification.inliers);
    loop->method = pr::toString(settings_.core.method);
    count(loop->robot_to == self ? "out loop_closures (own)" : "out loop_closures (teammates)");
    loop_pub_.publish(loop);
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    path_m_ += keyframe->travelled_m;  // also when the keyframe is dropped: the robot moved
    auto described = describe(*keyframe, "own");
    if (!described) return;
    described->path_m = path_m_;
    auto features = boost::make_shared<KeyframeFeatures>();
    features->header = keyframe->header;
    features->robot = keyframe->robot;
    features->keyframe_id = keyframe->id;
    features->vocabulary_hash = vocabularyHash();
    features->words = described->words;
    features->descriptor_count =
        static_cast<std::uint32_t>(described->scan.features.descriptors.size());
    count("out features");
    features_pub_.publish(features);
    // c_k of this keyframe with the teammates' keyframes whose word sets came before it.
    for (const auto& c : matcher_->teammateCorrespondences(described->words)) {
      auto reply = boost::make_shared<Correspondences>();
      reply->header.stamp = keyframe->header.stamp;
      reply->robot = settings_.frames.robot_name;
      reply->peer = c.robot;
      reply->peer_keyframe_id = c.keyframe;
      reply->keyframe_ids = {keyframe->id};
      reply->counts = {static_cast<std::uint32_t>(c.count)};
      count("out correspondences");
      correspondences_pub_.publish(reply);
    }
    // Teammates' scans kept so far may show this place too (they came before this robot did).
    const std::string& self = settings_.frames.robot_name;
    const auto kept = measured("match", [&] { return matcher_->matchKeptScans(*described); });
    const auto candidates =
        measured("match", [&] { return matcher_->addOwn(std::move(*described)); });
    places_ = matcher_->places();
    // Published once the keyframe is a place, so that each closure carries its pose.
    publishBest(kept, self, keyframe->id, keyframe->header.stamp);
    publishBest(candidates, self, keyframe->id, keyframe->header.stamp);
  }

  bool fromTeammate(const std::string& robot, const char* what) {
    if (robot != settings_.frames.robot_name) return true;
    NODELET_WARN_THROTTLE(5.0, "ignoring %s from this robot itself on the inbox (bridge loop?)",
                          what);
    count(std::string("dropped ") + what + " (own)");
    return false;
  }

  void onPeerFeatures(const KeyframeFeatures::ConstPtr& features) {
    count("in inbox/features");
    if (!fromTeammate(features->robot, "features")) return;
    if (features->vocabulary_hash != vocabularyHash()) {
      NODELET_WARN_THROTTLE(5.0,
                            "refusing features of %s keyframe %lu: vocabulary %s, this robot uses "
                            "%s (give every robot the same ~model_dir)",
                            features->robot.c_str(),
                            static_cast<unsigned long>(features->keyframe_id),
                            features->vocabulary_hash.c_str(), vocabularyHash().c_str());
      count("dropped features (other vocabulary)");
      return;
    }
    const auto& words = features->words;
    const bool sorted_unique =
        std::adjacent_find(words.begin(), words.end(),
                           [](std::uint32_t a, std::uint32_t b) { return a >= b; }) == words.end();
    if (!sorted_unique || (!words.empty() && words.back() >= matcher_->model().vocabulary.size())) {
      NODELET_WARN_THROTTLE(5.0,
                            "refusing features of %s keyframe %lu: word ids are not sorted, "
                            "unique and below %zu",
                            features->robot.c_str(),
                            static_cast<unsigned long>(features->keyframe_id),
                            matcher_->model().vocabulary.size());
      count("dropped features (malformed words)");
      return;
    }
    auto reply = boost::make_shared<Correspondences>();
    reply->header.stamp = features->header.stamp;
    reply->robot = settings_.frames.robot_name;
    reply->peer = features->robot;
    reply->peer_keyframe_id = features->keyframe_id;
    for (const auto& [keyframe, shared] : matcher_->correspondences(features->words)) {
      reply->keyframe_ids.push_back(keyframe);
      reply->counts.push_back(static_cast<std::uint32_t>(shared));
    }
    count("out correspondences");
    correspondences_pub_.publish(reply);
    matcher_->keepTeammateWords(features->robot, features->keyframe_id, features->words);
  }

  void onPeerScan(const Keyframe::ConstPtr& scan) {
    count("in teammate_scans", scan->cloud.data.size());
    if (!fromTeammate(scan->robot, "scans")) return;
    auto described = describe(*scan, "teammate");
    if (!described) return;
    publishBest(measured("match", [&] { return matcher_->matchTeammate(*described); }), scan->robot,
                scan->id, scan->header.stamp);
    matcher_->keepTeammateScan(scan->robot, std::move(*described));
    kept_ = matcher_->keptScans();
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    status.add("places", places_.load());
    status.add("teammate scans kept", kept_.load());
    status.add("candidates verified", verified_.load());
  }

  ros_params::MatcherSettings settings_;
  std::unique_ptr<pr::PlaceMatcher> matcher_;
  double path_m_ = 0.0;  // odometry path length of the own keyframes so far
  // For diagnostics, which run on another thread.
  std::atomic<std::size_t> places_{0};
  std::atomic<std::size_t> kept_{0};
  std::atomic<std::size_t> verified_{0};
  ros::Publisher features_pub_;
  ros::Publisher correspondences_pub_;
  ros::Publisher loop_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber inbox_features_sub_;
  ros::Subscriber teammate_scans_sub_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MatcherNodelet, nodelet::Nodelet)
