#include "ccir_mapping/core/place_recognition/place_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ccir_mapping::core::place_recognition {
namespace {

MatcherParams checked(const MatcherParams& params) {
  const auto errors = params.validate();
  if (!errors.empty()) throw std::invalid_argument(errors.front());
  return params;
}

const PlaceModel& required(const std::shared_ptr<const PlaceModel>& model) {
  if (!model) throw std::invalid_argument("PlaceMatcher needs a place-recognition model");
  return *model;
}

registration::VerificationParams verificationParams(const MatcherParams& params) {
  registration::VerificationParams v;
  v.min_inliers = params.min_inliers;
  v.max_fitness_m2 = params.max_fitness_m2;
  v.min_overlap = params.min_overlap;
  v.overlap_distance_m = params.overlap_distance_m;
  return v;
}

HistogramParams histogramParams(const MatcherParams& params) {
  HistogramParams h;
  h.min_votes = std::max(1, params.min_correspondences);
  return h;
}

}  // namespace

const MatchCandidate* bestAccepted(const std::vector<MatchCandidate>& candidates) {
  const MatchCandidate* best = nullptr;
  for (const auto& c : candidates) {
    if (!c.verification.accepted) continue;
    const auto rank = [](const MatchCandidate& m) {
      return std::make_pair(m.verification.overlap, m.verification.inliers);
    };
    if (!best || rank(c) > rank(*best)) best = &c;
  }
  return best;
}

PlaceMatcher::PlaceMatcher(const MatcherParams& params, std::shared_ptr<const PlaceModel> model)
    : params_(checked(params)),
      model_(std::move(model)),
      extractor_(required(model_).features),
      verifier_(verificationParams(params_)),
      fabmap_model_(model_->tree, FabMapParams{}),
      fabmap_(fabmap_model_, model_->samples),
      histogram_(histogramParams(params_)),
      postings_(model_->vocabulary.size()) {}

DescribedKeyframe PlaceMatcher::describe(KeyframeId id, Stamp stamp,
                                         const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                         const Eigen::Vector3f& up) const {
  return describe(id, stamp, cloud, extractor_.extract(cloud, up));
}

DescribedKeyframe PlaceMatcher::describe(KeyframeId id, Stamp stamp,
                                         const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                         features::LocalFeatures features) const {
  DescribedKeyframe k;
  k.id = id;
  k.stamp = stamp;
  k.words = model_->vocabulary.quantize(features.descriptors);
  k.scan = verifier_.prepare(cloud, std::move(features));
  return k;
}

std::vector<int> PlaceMatcher::sharedWords(const WordSet& words) const {
  std::vector<int> shared(places_.size(), 0);
  for (const std::uint32_t w : words) {
    if (w >= postings_.size()) continue;  // a foreign vocabulary is refused before this
    for (const std::uint32_t place : postings_[w]) ++shared[place];
  }
  return shared;
}

std::vector<std::pair<KeyframeId, int>> PlaceMatcher::correspondences(const WordSet& words) const {
  const std::vector<int> shared = sharedWords(words);
  std::vector<std::pair<KeyframeId, int>> result;
  for (std::size_t i = 0; i < shared.size(); ++i) {
    if (shared[i] > 0 && shared[i] >= params_.min_correspondences) {
      result.emplace_back(places_[i].id, shared[i]);
    }
  }
  std::stable_sort(result.begin(), result.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return result;
}

std::vector<MatchCandidate> PlaceMatcher::match(const DescribedKeyframe& query,
                                                Stamp newest) const {
  const std::vector<int> shared = sharedWords(query.words);
  auto eligible = [&](std::size_t place) { return places_[place].stamp <= newest; };
  // Ranked places: (index, score).
  std::vector<std::pair<std::size_t, double>> ranked;
  if (params_.method == MatchMethod::kFabmap) {
    const std::vector<double> posterior = fabmap_.posterior(query.words);
    for (std::size_t i = 0; i < places_.size(); ++i) {
      if (eligible(i) && shared[i] >= params_.min_correspondences) {
        ranked.emplace_back(i, posterior[i]);
      }
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
  } else {
    for (const auto& peak : histogram_.candidates(query.scan.features.descriptors)) {
      if (eligible(peak.keyframe)) ranked.emplace_back(peak.keyframe, peak.votes);
    }
  }
  if (ranked.size() > static_cast<std::size_t>(params_.max_candidates)) {
    ranked.resize(static_cast<std::size_t>(params_.max_candidates));
  }
  std::vector<MatchCandidate> candidates;
  for (const auto& [place, score] : ranked) {
    MatchCandidate c;
    c.keyframe = places_[place].id;
    c.score = score;
    c.correspondences = shared[place];
    c.verification = verifier_.verify(places_[place].scan, query.scan);
    candidates.push_back(std::move(c));
  }
  return candidates;
}

void PlaceMatcher::gateByOdometry(const DescribedKeyframe& query, MatchCandidate& c) const {
  const DescribedKeyframe& place = places_[place_of_.at(c.keyframe)];
  if (!c.verification.accepted || !query.odom_pose || !place.odom_pose ||
      params_.own_loop_gate_m_per_m <= 0.0 || params_.own_loop_gate_rad_per_m <= 0.0) {
    return;
  }
  const Pose3 odometry = place.odom_pose->inverse() * *query.odom_pose;
  const Pose3 disagreement = odometry.inverse() * c.verification.relative;
  const double path_m = std::abs(query.path_m - place.path_m);
  const double shift_m = disagreement.translation().norm();
  const double turn_rad = Eigen::AngleAxisd(disagreement.linear()).angle();
  const double max_shift_m = 1.0 + params_.own_loop_gate_m_per_m * path_m;
  const double max_turn_rad = 0.2 + params_.own_loop_gate_rad_per_m * path_m;
  if (shift_m > max_shift_m || turn_rad > max_turn_rad) {
    c.verification.accepted = false;
    c.verification.reason = "odometry disagrees by " + std::to_string(shift_m) + " m, " +
                            std::to_string(turn_rad) + " rad after " + std::to_string(path_m) +
                            " m (gate " + std::to_string(max_shift_m) + " m, " +
                            std::to_string(max_turn_rad) + " rad)";
  }
}

std::vector<MatchCandidate> PlaceMatcher::addOwn(DescribedKeyframe keyframe) {
  const Stamp newest = keyframe.stamp - fromSeconds(params_.loop_exclusion_s);
  auto candidates = match(keyframe, newest);
  for (auto& c : candidates) gateByOdometry(keyframe, c);
  const auto index = static_cast<std::uint32_t>(places_.size());
  place_of_[keyframe.id] = index;
  for (const std::uint32_t w : keyframe.words) {
    if (w < postings_.size()) postings_[w].push_back(index);
  }
  fabmap_.addPlace(keyframe.words);
  histogram_.addKeyframe(index, keyframe.scan.features.descriptors);
  places_.push_back(std::move(keyframe));
  return candidates;
}

std::vector<MatchCandidate> PlaceMatcher::matchTeammate(const DescribedKeyframe& keyframe) const {
  return match(keyframe, std::numeric_limits<Stamp>::max());
}

}  // namespace ccir_mapping::core::place_recognition
