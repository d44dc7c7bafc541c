// Loop-closure detection for one robot: its keyframes become places (FAB-MAP 2.0 or the
// histogram baseline); an own keyframe is matched against older own places and against the
// teammates' scans kept so far, a teammate's scan against every own place. Candidates inside a
// pose gate (PoseGate) are verified at once, a few of them; those found without a pose prior
// are verified within a budget (VerificationQueue).
#pragma once

#include <algorithm>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/hgmm/gaussian_mixture.h"
#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/histogram_matcher.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "ccir_mapping/core/place_recognition/pose_gate.h"
#include "ccir_mapping/core/place_recognition/verification_queue.h"
#include "ccir_mapping/core/pose_graph/loop_closure.h"
#include "ccir_mapping/core/registration/scan_verifier.h"

namespace ccir_mapping::core::place_recognition {

/// A keyframe as place recognition sees it.
struct DescribedKeyframe {
  KeyframeId id = 0;
  Stamp stamp = 0;
  /// The sensor pose from odometry (in its robot's frame), and for own keyframes the odometry
  /// path length up to it, which bound how far a loop closure may move it (describeOwn).
  std::optional<Pose3> odom_pose;
  double path_m = 0.0;
  WordSet words;
  registration::PreparedScan scan;
  /// With methods scan_context and hgmm: the descriptor of the cloud levelled by `level`
  /// (sensor frame to one whose z is up).
  std::optional<ScanContext> context;
  Eigen::Matrix3d level = Eigen::Matrix3d::Identity();
  /// With method hgmm: the deepest level of the levelled verification cloud's HGMM.
  std::optional<hgmm::GaussianMixture> mixture;
};

struct MatchCandidate {
  /// The place: an own keyframe (robot empty) or a kept scan of the teammate `robot`.
  std::string robot;
  KeyframeId keyframe = 0;
  /// FAB-MAP posterior, histogram votes, 1 - the Scan Context distance, or the similarity of the
  /// registered mixtures.
  double score = 0.0;
  /// FAB-MAP: the query's p(new place) (the same for each of its candidates); the histogram
  /// has none: -1.
  double new_place_probability = -1.0;
  /// c_k: words shared with the query.
  int correspondences = 0;
  /// "from" is always this robot's keyframe (for own loops the older one), "to" the other.
  registration::Verification verification;
};

/// The accepted candidate with the largest wall overlap (then most inliers), or nullptr.
const MatchCandidate* bestAccepted(const std::vector<MatchCandidate>& candidates);

class PlaceMatcher {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors or the model is null.
  PlaceMatcher(const MatcherParams& params, std::shared_ptr<const PlaceModel> model);
  ~PlaceMatcher();

  const PlaceModel& model() const { return *model_; }
  std::size_t places() const;
  /// The odometry pose of an own place (keyframe), if it is one and had one.
  std::optional<Pose3> placeOdomPose(KeyframeId id) const;
  /// `match`, found for keyframe `query` of `query_robot` (robot `self`'s own or a teammate's,
  /// then with its odometry pose `query_odom_pose`), as a loop closure: "from" is always this
  /// robot's keyframe (of an own loop the older one, the place), with its odometry pose when it
  /// is a place that had one; an inter-robot one carries the teammate's keyframe's odometry pose
  /// (odom_pose_to) when known, so that a third robot can place it.
  pose_graph::LoopClosureData loopClosure(const std::string& self, const MatchCandidate& match,
                                          const std::string& query_robot, KeyframeId query,
                                          const std::optional<Pose3>& query_odom_pose = {}) const;

  /// Features (with the model's settings), words and verification cloud of a keyframe cloud in
  /// its sensor frame; `up` is gravity's opposite in that frame.
  DescribedKeyframe describe(KeyframeId id, Stamp stamp,
                             const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                             const Eigen::Vector3f& up) const;
  /// An own keyframe, described with its odometry pose (gravity comes from it) and the odometry
  /// path length so far (addOwnTravel), which bound how far a loop closure may move it.
  DescribedKeyframe describeOwn(KeyframeId id, Stamp stamp,
                                const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                const Pose3& odom_pose) const;
  /// A teammate's keyframe, described with its odometry pose in the teammate's frame (gravity
  /// comes from it; the closures found with it carry it). `drawn_from_mixture`: its points were
  /// drawn from the mixture it crossed the link as (verified with the mixture tolerances).
  DescribedKeyframe describeTeammate(KeyframeId id, Stamp stamp,
                                     const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                     const Pose3& odom_pose, bool drawn_from_mixture = false) const;
  /// Counts the odometry distance to an own keyframe (also to one that is dropped: the robot
  /// moved all the same).
  void addOwnTravel(double travelled_m) { path_m_ += travelled_m; }
  /// The same for features already extracted with model().features.
  DescribedKeyframe describe(KeyframeId id, Stamp stamp,
                             const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                             features::LocalFeatures features, const Eigen::Vector3f& up,
                             bool drawn_from_mixture = false) const;

  /// Why a teammate's word set cannot be used, or nullopt: made with another vocabulary (kind
  /// "other vocabulary"), or ids not sorted, unique and below the vocabulary's size ("malformed
  /// words").
  std::optional<Notice> wordsProblem(const std::string& vocabulary_hash,
                                     const WordSet& words) const;

  /// c_k of every local place sharing at least min_correspondences words, most first.
  std::vector<std::pair<KeyframeId, int>> correspondences(const WordSet& words) const;

  /// A teammate's word set, kept so an own keyframe made later gets its c_k with it too.
  void keepTeammateWords(const std::string& robot, KeyframeId id, WordSet words);
  struct TeammateCorrespondence {
    std::string robot;
    KeyframeId keyframe = 0;
    int count = 0;
  };
  /// Per teammate, its kept keyframe sharing the most words with `words` (at least
  /// min_correspondences): the c_k a new own keyframe has with that teammate.
  std::vector<TeammateCorrespondence> teammateCorrespondences(const WordSet& words) const;

  /// Matches an own keyframe against own places at least loop_exclusion_s older, then adds it
  /// as a place. With its odometry pose, only places in the pose gate are candidates, and the
  /// search.gated_candidates best-ranked are verified; without, the max_candidates best.
  /// Returns the verified candidates, best-ranked first; a verified closure that moves the
  /// keyframe farther from where odometry puts it than the drift gate allows is not accepted
  /// (perceptual aliasing). Accepted ones anchor the gate.
  std::vector<MatchCandidate> addOwn(DescribedKeyframe keyframe);

  /// Matches a teammate's keyframe against every own place (it does not become a place): those
  /// in the gate of an accepted closure with that teammate are verified at once and returned,
  /// the others queued (or, without a budget, verified and returned too).
  std::vector<MatchCandidate> matchTeammate(const std::string& robot,
                                            const DescribedKeyframe& keyframe);

  /// Keeps a teammate's scan, so that own keyframes made later are matched against it.
  void keepTeammateScan(const std::string& robot, DescribedKeyframe keyframe);
  std::size_t keptScans() const;

  /// Matches an own keyframe (not yet added) against the kept teammate scans, as matchTeammate.
  std::vector<MatchCandidate> matchKeptScans(const DescribedKeyframe& keyframe);

  /// A closure a teammate found between one of its keyframes ("from", with its odometry pose)
  /// and one of this robot's places ("to", robot `self`): it anchors the gate for that teammate,
  /// so that this robot need not find a first closure with it through the budget. Others (with
  /// a third robot, or without the pose) are ignored.
  void addTeammateClosure(const std::string& self, const pose_graph::LoopClosureData& loop);
  /// The pose gate's anchors for robot `robot` ("" for own loops).
  std::size_t anchors(const std::string& robot) const { return gate_.anchors(robot).size(); }

  /// A candidate verified from the queue: this robot's keyframe `own` and the teammate's.
  struct QueuedMatch {
    KeyframeId own = 0;
    MatchCandidate candidate;
    double waited_s = 0.0;  // mission seconds in the queue
  };
  /// Verifies the queued candidates the budget pays for up to the newest stamp seen.
  std::vector<QueuedMatch> verifyQueued();
  /// Candidates waiting for the budget, and those dropped unverified after the horizon.
  std::size_t queued() const;
  std::size_t expired() const;

 private:
  class PlaceSet;

  /// A place ranked by a method, with the pose of "to" in "from" its ranking found (hgmm).
  struct Ranked {
    std::size_t index = 0;
    double score = 0.0;
    std::optional<Pose3> initial;
    int correspondences = 0;  // c_k
  };
  /// `set`'s places accepted by `eligible`, ranked by the method, best first; `query_is_from`:
  /// the query is the own keyframe ("from") rather than the place. `motion`: null for a
  /// uniform prior over the places, else the posterior of the query before along the same path
  /// (empty at first) for FAB-MAP's motion prior, replaced by this one's.
  std::vector<Ranked> rank(PlaceSet& set, const DescribedKeyframe& query,
                           const std::function<bool(const DescribedKeyframe&)>& eligible,
                           bool query_is_from, std::vector<double>* motion,
                           double* new_place_probability) const;
  std::vector<MatchCandidate> verify(PlaceSet& set, const DescribedKeyframe& query,
                                     const std::vector<Ranked>& ranked, bool query_is_from,
                                     double new_place_probability) const;
  /// The first gated_candidates of `ranked` in the gate (gate[i] <= 1), the nearest to where
  /// the prior puts them first.
  std::vector<Ranked> nearestGated(const std::vector<Ranked>& ranked,
                                   const std::vector<double>& gate) const;
  /// A teammate query's ranking split: the nearest gated places verified now, the rest of the
  /// first max_candidates queued (or verified now without a budget). `own_of`: this robot's
  /// keyframe of a ranked place's pair; `teammate_of`: the teammate's.
  std::vector<MatchCandidate> searchTeammates(
      PlaceSet& set, const DescribedKeyframe& query, const std::vector<Ranked>& ranked,
      const std::vector<double>& gate, bool query_is_from, double new_place_probability,
      const std::function<KeyframeId(const Ranked&)>& own_of,
      const std::function<std::pair<std::string, KeyframeId>(const Ranked&)>& teammate_of);
  /// gate[i]: for the places of `set` (in robot `robot`'s frame) near where `robot`'s anchors
  /// predict `query`, the smallest PoseGate::ratio (the others are left as they were; <= 1:
  /// admitted). `query_is_own` when the query is this robot's keyframe and the places `robot`'s,
  /// else the query is `robot`'s and the places this robot's.
  void gateRatios(const PlaceSet& set, const std::string& robot, const DescribedKeyframe& query,
                  bool query_is_own, std::vector<double>& gate) const;
  /// An accepted closure between own keyframe `own` and `other` (of `robot`, "" for own) as a
  /// gate anchor; `relative`: the pose of `other` in `own`.
  void anchor(const std::string& robot, const DescribedKeyframe& own,
              const DescribedKeyframe& other, const Pose3& relative);
  bool gateOn() const { return params_.own_loop_gate_m_per_m > 0.0; }
  void sawStamp(Stamp stamp) { newest_stamp_ = std::max(newest_stamp_, stamp); }
  /// Method hgmm: the places whose mixtures registered to the query's, most similar first.
  std::vector<Ranked> rankByMixtures(const PlaceSet& set, const DescribedKeyframe& query,
                                     const std::function<bool(const DescribedKeyframe&)>& eligible,
                                     bool query_is_from) const;
  void gateByOdometry(const DescribedKeyframe& query, MatchCandidate& candidate) const;
  const DescribedKeyframe& ownPlace(KeyframeId id) const;
  const DescribedKeyframe* place(const PlaceSet& set, const std::string& robot,
                                 KeyframeId id) const;
  /// The place's scan, complete for verification (ScanVerifier::complete).
  const registration::PreparedScan& ready(PlaceSet& set, std::size_t index) const;
  /// Marks the place as used last; the least recently used beyond complete_places are
  /// compacted (ScanVerifier::compact), which bounds the matcher's memory.
  void remember(PlaceSet& set, std::size_t index) const;

  MatcherParams params_;
  std::shared_ptr<const PlaceModel> model_;
  features::FeatureExtractor extractor_;
  registration::ScanVerifier verifier_;
  FabMapModel fabmap_model_;
  std::unique_ptr<PlaceSet> own_;
  std::unique_ptr<PlaceSet> kept_;  // teammates' scans
  PoseGate gate_;
  std::optional<VerificationQueue> queue_;  // without a budget: none
  Stamp newest_stamp_ = 0;
  /// Teammates' word sets by robot and keyframe.
  std::map<std::string, std::map<KeyframeId, WordSet>> teammate_words_;
  double path_m_ = 0.0;  // odometry path length of the own keyframes so far
  /// FAB-MAP's posterior for the last own keyframe, over the own places then new.
  std::vector<double> own_posterior_;
  /// Places whose scans are complete, least recently used first (own and teammates').
  mutable std::deque<std::pair<PlaceSet*, std::size_t>> recent_;
};

}  // namespace ccir_mapping::core::place_recognition
