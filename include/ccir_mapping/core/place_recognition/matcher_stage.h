// The Matcher's stage: one robot's place recognition (PlaceMatcher) in the shape every stage
// has. Each input goes in as plain data and an Output comes back with everything the caller
// must pass on (an own keyframe's word set for the teammates, c_k for the Broker, the verified
// loop closures) and what was refused. The Matcher nodelet and the team runner (core/runner)
// both run it, so that neither decides anything of its own.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/place_recognition/place_matcher.h"

namespace ccir_mapping::core::place_recognition {

/// A keyframe's word set as teammates receive it (KeyframeFeatures): what CCIR sends instead of
/// descriptors.
struct KeyframeWords {
  std::string robot;
  KeyframeId id = 0;
  Stamp stamp = 0;
  std::string vocabulary_hash;
  WordSet words;
  std::uint32_t descriptor_count = 0;
};

/// c_k of this robot's keyframes with one teammate keyframe (Correspondences): the Broker's
/// loop-closure potential.
struct KeyframeCorrespondences {
  std::string peer;
  KeyframeId peer_keyframe = 0;
  std::vector<std::pair<KeyframeId, int>> counts;  // own keyframe, c_k
};

class MatcherStage {
 public:
  using Cloud = pcl::PointCloud<pcl::PointXYZINormal>;

  struct Output {
    /// An own keyframe's word set, for every teammate.
    std::optional<KeyframeWords> features;
    std::vector<KeyframeCorrespondences> correspondences;
    /// The best verified candidate of each query, as a loop closure, and the mission seconds
    /// each waited for the verification budget after both its keyframes were here (0: at once).
    std::vector<pose_graph::LoopClosureData> loop_closures;
    std::vector<double> waited_s;
    /// Inputs refused, by kind ("features (other vocabulary)", "scans (own)", ...).
    std::vector<Notice> refused;
    /// Candidates verified geometrically.
    std::size_t verified = 0;
  };

  /// Runs a piece of work ("describe", "match") and lets the caller measure it.
  struct Hooks {
    std::function<void(const char* stage, const std::function<void()>& work)> run =
        [](const char*, const std::function<void()>& work) { work(); };
  };

  /// Throws std::invalid_argument when params.validate() reports errors or the model is null.
  MatcherStage(std::string robot, const MatcherParams& params,
               std::shared_ptr<const PlaceModel> model, Hooks hooks);
  MatcherStage(std::string robot, const MatcherParams& params,
               std::shared_ptr<const PlaceModel> model);

  const PlaceMatcher& matcher() const { return matcher_; }
  const std::string& vocabularyHash() const { return matcher_.model().vocabulary.hash(); }

  /// The odometry distance to an own keyframe, counted also for one the caller could not read
  /// (the robot moved all the same): it bounds how far a loop closure may move a keyframe.
  void addOwnTravel(double travelled_m) { matcher_.addOwnTravel(travelled_m); }
  /// An own keyframe (sensor frame) described into `described`: its word set for the
  /// teammates and its c_k with the teammates' word sets kept so far. Publish these before
  /// matchOwn(), which takes most of the time.
  Output describeOwn(KeyframeId id, Stamp stamp, const Cloud& cloud, const Pose3& odom_pose,
                     DescribedKeyframe* described);
  /// That keyframe matched against the teammates' scans kept so far (they came before this
  /// robot did) and the older own places, then kept as a place: its loop closures.
  Output matchOwn(DescribedKeyframe described);
  /// A teammate's word set: c_k of the own places, kept for the own keyframes to come; refused
  /// when it is this robot's own (a bridge loop), of another vocabulary or malformed.
  Output onTeammateWords(const KeyframeWords& words);
  /// A loop closure a teammate found with one of this robot's keyframes: a pose prior for the
  /// search with that teammate (PlaceMatcher::addTeammateClosure).
  void onTeammateClosure(const pose_graph::LoopClosureData& loop) {
    matcher_.addTeammateClosure(robot_, loop);
  }
  /// A teammate's scan (sensor frame, odometry pose in the teammate's frame; drawn from the
  /// mixture it crossed the link as): matched against every own place, then kept so that own
  /// keyframes made later are matched against it; refused when it is this robot's own.
  Output onTeammateScan(const std::string& robot, KeyframeId id, Stamp stamp, const Cloud& cloud,
                        const Pose3& odom_pose, bool drawn_from_mixture);

 private:
  /// The best accepted of `candidates` (found for keyframe `query` of `query_robot`) as a loop
  /// closure in `out`.
  void closeLoop(const std::vector<MatchCandidate>& candidates, const std::string& query_robot,
                 KeyframeId query, const std::optional<Pose3>& query_odom_pose, Output& out) const;
  /// The queued candidates the verification budget now pays for; each accepted one as a loop
  /// closure in `out`.
  void verifyQueued(Output& out);
  template <class F>
  auto measured(const char* stage, F&& work);

  const std::string robot_;
  Hooks hooks_;
  PlaceMatcher matcher_;
};

}  // namespace ccir_mapping::core::place_recognition
