// Loop-closure detection for one robot: its keyframes become places (FAB-MAP 2.0 or the
// histogram baseline); an own keyframe is matched against older own places and a teammate's
// keyframe against all of them; the best-ranked candidates are verified geometrically.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/histogram_matcher.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "ccir_mapping/core/registration/scan_verifier.h"

namespace ccir_mapping::core::place_recognition {

/// A keyframe as place recognition sees it.
struct DescribedKeyframe {
  KeyframeId id = 0;
  Stamp stamp = 0;
  /// Own keyframes: the sensor pose from odometry and the odometry path length up to it, which
  /// bound how far a loop closure may move it (teammates' keyframes leave them unset).
  std::optional<Pose3> odom_pose;
  double path_m = 0.0;
  WordSet words;
  registration::PreparedScan scan;
};

struct MatchCandidate {
  /// The local place.
  KeyframeId keyframe = 0;
  /// FAB-MAP posterior, or histogram votes.
  double score = 0.0;
  /// c_k: words shared with the query.
  int correspondences = 0;
  /// "from" = the local place, "to" = the query.
  registration::Verification verification;
};

/// The accepted candidate with the largest wall overlap (then most inliers), or nullptr.
const MatchCandidate* bestAccepted(const std::vector<MatchCandidate>& candidates);

class PlaceMatcher {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors or the model is null.
  PlaceMatcher(const MatcherParams& params, std::shared_ptr<const PlaceModel> model);

  const PlaceModel& model() const { return *model_; }
  std::size_t places() const { return places_.size(); }

  /// Features (with the model's settings), words and verification cloud of a keyframe cloud in
  /// its sensor frame; `up` is gravity's opposite in that frame.
  DescribedKeyframe describe(KeyframeId id, Stamp stamp,
                             const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                             const Eigen::Vector3f& up) const;
  /// The same for features already extracted with model().features.
  DescribedKeyframe describe(KeyframeId id, Stamp stamp,
                             const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                             features::LocalFeatures features) const;

  /// c_k of every local place sharing at least min_correspondences words, most first.
  std::vector<std::pair<KeyframeId, int>> correspondences(const WordSet& words) const;

  /// Matches an own keyframe against own places at least loop_exclusion_s older, then adds it
  /// as a place. Returns the verified candidates, best-ranked first; with odometry on both
  /// keyframes, a verified closure that moves the keyframe farther from where odometry puts it
  /// than the drift gate allows is not accepted (perceptual aliasing).
  std::vector<MatchCandidate> addOwn(DescribedKeyframe keyframe);

  /// Matches a teammate's keyframe against every place; it does not become a place.
  std::vector<MatchCandidate> matchTeammate(const DescribedKeyframe& keyframe) const;

 private:
  std::vector<MatchCandidate> match(const DescribedKeyframe& query, Stamp newest) const;
  void gateByOdometry(const DescribedKeyframe& query, MatchCandidate& candidate) const;
  std::vector<int> sharedWords(const WordSet& words) const;

  MatcherParams params_;
  std::shared_ptr<const PlaceModel> model_;
  features::FeatureExtractor extractor_;
  registration::ScanVerifier verifier_;
  FabMapModel fabmap_model_;
  FabMap2 fabmap_;
  HistogramMatcher histogram_;
  std::vector<DescribedKeyframe> places_;
  std::map<KeyframeId, std::size_t> place_of_;        // keyframe id -> index in places_
  std::vector<std::vector<std::uint32_t>> postings_;  // word -> places holding it
};

}  // namespace ccir_mapping::core::place_recognition
