#include "ccir_mapping/core/place_recognition/place_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/hgmm/hgmm.h"
#include "ccir_mapping/core/hgmm/mixture_registration.h"
#include "ccir_mapping/core/place_recognition/place_positions.h"
#include "ccir_mapping/core/place_recognition/scan_context_index.h"

namespace ccir_mapping::core::place_recognition {
namespace {

const PlaceModel& required(const std::shared_ptr<const PlaceModel>& model) {
  if (!model) throw std::invalid_argument("PlaceMatcher needs a place-recognition model");
  return *model;
}

PoseGate::Params gateParams(const MatcherParams& params) {
  PoseGate::Params g;
  g.drift_m_per_m = params.own_loop_gate_m_per_m;
  g.max_drift_m = params.search.max_drift_m;
  g.reach_m = params.search.reach_m;
  return g;
}

/// A gate ratio for places no prior admits.
constexpr double kOutside = std::numeric_limits<double>::infinity();

/// The histogram's index, with method histogram only: it holds a copy of every place's
/// descriptors (~0.1 MB a place).
std::optional<HistogramParams> histogramParams(const MatcherParams& params) {
  if (params.method != MatchMethod::kHistogram) return std::nullopt;
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

/// Places with their indices: FAB-MAP 2.0 (whose inverted index also gives c_k), the
/// histogram (if given its parameters), Scan Context, and the places' odometry positions in
/// each robot's frame.
class PlaceMatcher::PlaceSet {
 public:
  PlaceSet(const FabMapModel& model, const std::vector<WordSet>& samples,
           const std::optional<HistogramParams>& histogram_params,
           const ScanContextParams& scan_context)
      : fabmap(model, samples), scan_context(scan_context) {
    if (histogram_params) histogram.emplace(*histogram_params);
  }

  void add(const std::string& robot, DescribedKeyframe keyframe) {
    const auto index = static_cast<std::uint32_t>(places.size());
    fabmap.addPlace(keyframe.words);
    if (histogram) histogram->addKeyframe(index, keyframe.scan.features.descriptors);
    // Every place has one with method scan_context, so the index's places are these.
    if (keyframe.context) scan_context.add(*keyframe.context);
    if (keyframe.odom_pose) positions[robot].add(index, keyframe.odom_pose->translation());
    index_of[{robot, keyframe.id}] = index;
    robots.push_back(robot);
    places.push_back(std::move(keyframe));
  }

  std::vector<DescribedKeyframe> places;
  std::vector<std::string> robots;  // of each place; empty for own keyframes
  std::map<std::pair<std::string, KeyframeId>, std::size_t> index_of;
  FabMap2 fabmap;
  std::optional<HistogramMatcher> histogram;
  ScanContextIndex scan_context;
  std::map<std::string, PlacePositions> positions;  // by robot, "" = this one
};

PlaceMatcher::PlaceMatcher(const MatcherParams& params, std::shared_ptr<const PlaceModel> model)
    : params_(validated(params)),
      model_(std::move(model)),
      extractor_(required(model_).features),
      verifier_(params_.verification),
      fabmap_model_(model_->tree, params_.fabmap),
      own_(std::make_unique<PlaceSet>(fabmap_model_, model_->samples, histogramParams(params_),
                                      params_.scan_context)),
      kept_(std::make_unique<PlaceSet>(fabmap_model_, model_->samples, histogramParams(params_),
                                       params_.scan_context)),
      gate_(gateParams(params_)) {
  if (params_.search.prior_free_verifications_per_s > 0.0) {
    queue_.emplace(params_.search.prior_free_verifications_per_s,
                   params_.search.prior_free_horizon_s);
  }
}

PlaceMatcher::~PlaceMatcher() = default;

std::size_t PlaceMatcher::places() const { return own_->places.size(); }
std::size_t PlaceMatcher::keptScans() const { return kept_->places.size(); }
std::size_t PlaceMatcher::queued() const { return queue_ ? queue_->size() : 0; }
std::size_t PlaceMatcher::expired() const { return queue_ ? queue_->expired() : 0; }

pose_graph::LoopClosureData PlaceMatcher::loopClosure(
    const std::string& self, const MatchCandidate& match, const std::string& query_robot,
    KeyframeId query, const std::optional<Pose3>& query_odom_pose) const {
  // An own query meeting a teammate's kept scan is "from"; otherwise the place is.
  const bool own_query_meets_teammate = query_robot == self && !match.robot.empty();
  pose_graph::LoopClosureData loop;
  loop.robot_from = self;
  loop.keyframe_from = own_query_meets_teammate ? query : match.keyframe;
  loop.robot_to = match.robot.empty() ? query_robot : match.robot;
  loop.keyframe_to = own_query_meets_teammate ? match.keyframe : query;
  loop.relative = match.verification.relative;
  loop.covariance = match.verification.covariance;
  loop.odom_pose_from = placeOdomPose(loop.keyframe_from);
  if (own_query_meets_teammate) {
    const auto kept = kept_->index_of.find({match.robot, match.keyframe});
    if (kept != kept_->index_of.end()) loop.odom_pose_to = kept_->places[kept->second].odom_pose;
  } else if (loop.robot_to != self) {
    loop.odom_pose_to = query_odom_pose;
  }
  loop.match_score = match.score;
  loop.new_place_probability = match.new_place_probability;
  loop.fitness_m2 = match.verification.fitness_m2;
  loop.inliers = match.verification.inliers;
  loop.method = toString(params_.method);
  return loop;
}

std::optional<Pose3> PlaceMatcher::placeOdomPose(KeyframeId id) const {
  const auto it = own_->index_of.find({std::string(), id});
  if (it == own_->index_of.end()) return std::nullopt;
  return own_->places[it->second].odom_pose;
}

DescribedKeyframe PlaceMatcher::describe(KeyframeId id, Stamp stamp,
                                         const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                         const Eigen::Vector3f& up) const {
  return describe(id, stamp, cloud, extractor_.extract(cloud, up), up);
}

DescribedKeyframe PlaceMatcher::describe(KeyframeId id, Stamp stamp,
                                         const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                         features::LocalFeatures features,
                                         const Eigen::Vector3f& up, bool drawn_from_mixture) const {
  DescribedKeyframe k;
  k.id = id;
  k.stamp = stamp;
  k.words = model_->vocabulary.quantize(features.descriptors);
  k.scan = verifier_.prepare(cloud, std::move(features), drawn_from_mixture);
  if (params_.method == MatchMethod::kScanContext || params_.method == MatchMethod::kHgmm) {
    // Scan Context bins by azimuth and height, and mixtures are registered from a heading: in a
    // frame whose z is up.
    k.level = Eigen::Quaterniond::FromTwoVectors(up.cast<double>(), Eigen::Vector3d::UnitZ())
                  .toRotationMatrix();
    const Eigen::Matrix3f level = k.level.cast<float>();
    pcl::PointCloud<pcl::PointXYZ> levelled;
    levelled.reserve(cloud.size());
    for (const auto& p : cloud) {
      const Eigen::Vector3f q = level * p.getVector3fMap();
      levelled.push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
    }
    k.context.emplace(levelled, params_.scan_context);
  }
  if (params_.method == MatchMethod::kHgmm) {
    const auto& points = *k.scan.cloud;
    hgmm::Points levelled(3, static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) {
      levelled.col(static_cast<Eigen::Index>(i)) =
          k.level * points[i].getVector3fMap().cast<double>();
    }
    k.mixture =
        points.empty()
            ? hgmm::GaussianMixture()
            : hgmm::Hgmm::build(levelled, params_.hgmm.model).level(params_.hgmm.model.max_depth);
  }
  return k;
}

DescribedKeyframe PlaceMatcher::describeOwn(KeyframeId id, Stamp stamp,
                                            const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                            const Pose3& odom_pose) const {
  DescribedKeyframe k = describe(id, stamp, cloud, upInFrame(odom_pose));
  k.odom_pose = odom_pose;
  k.path_m = path_m_;
  return k;
}

DescribedKeyframe PlaceMatcher::describeTeammate(KeyframeId id, Stamp stamp,
                                                 const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                                 const Pose3& odom_pose,
                                                 bool drawn_from_mixture) const {
  const Eigen::Vector3f up = upInFrame(odom_pose);
  DescribedKeyframe k =
      describe(id, stamp, cloud, extractor_.extract(cloud, up), up, drawn_from_mixture);
  k.odom_pose = odom_pose;
  return k;
}

std::optional<Notice> PlaceMatcher::wordsProblem(const std::string& vocabulary_hash,
                                                 const WordSet& words) const {
  const Vocabulary& vocabulary = model_->vocabulary;
  if (vocabulary_hash != vocabulary.hash()) {
    return Notice{"other vocabulary", "vocabulary " + vocabulary_hash + ", this robot uses " +
                                          vocabulary.hash() +
                                          " (give every robot the same model_dir)"};
  }
  const bool sorted_unique =
      std::adjacent_find(words.begin(), words.end(),
                         [](std::uint32_t a, std::uint32_t b) { return a >= b; }) == words.end();
  if (!sorted_unique || (!words.empty() && words.back() >= vocabulary.size())) {
    return Notice{"malformed words",
                  "word ids are not sorted, unique and below " + std::to_string(vocabulary.size())};
  }
  return std::nullopt;
}

std::vector<std::pair<KeyframeId, int>> PlaceMatcher::correspondences(const WordSet& words) const {
  const std::vector<int> shared = own_->fabmap.sharedWords(words);
  std::vector<std::pair<KeyframeId, int>> result;
  for (std::size_t i = 0; i < shared.size(); ++i) {
    if (shared[i] > 0 && shared[i] >= params_.min_correspondences) {
      result.emplace_back(own_->places[i].id, shared[i]);
    }
  }
  std::stable_sort(result.begin(), result.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return result;
}

void PlaceMatcher::keepTeammateWords(const std::string& robot, KeyframeId id, WordSet words) {
  teammate_words_[robot][id] = std::move(words);
}

std::vector<PlaceMatcher::TeammateCorrespondence> PlaceMatcher::teammateCorrespondences(
    const WordSet& words) const {
  // Sorted word sets of a few dozen words: a merge per kept set is cheaper than an index.
  std::vector<TeammateCorrespondence> result;
  for (const auto& [robot, sets] : teammate_words_) {
    TeammateCorrespondence best{robot, 0, 0};
    for (const auto& [id, other] : sets) {
      int shared = 0;
      for (auto a = words.begin(), b = other.begin(); a != words.end() && b != other.end();) {
        if (*a < *b) {
          ++a;
        } else if (*b < *a) {
          ++b;
        } else {
          ++shared, ++a, ++b;
        }
      }
      if (shared > best.count) best = {robot, id, shared};
    }
    if (best.count > 0 && best.count >= params_.min_correspondences) result.push_back(best);
  }
  return result;
}

std::vector<PlaceMatcher::Ranked> PlaceMatcher::rank(
    PlaceSet& set, const DescribedKeyframe& query,
    const std::function<bool(const DescribedKeyframe&)>& eligible, bool query_is_from,
    std::vector<double>* motion, double* new_place_probability) const {
  const std::vector<int> shared = set.fabmap.sharedWords(query.words);
  std::vector<Ranked> ranked;
  *new_place_probability = -1.0;
  if (params_.method == MatchMethod::kFabmap) {
    // Places the query may not match are left out of the prior, so they take no mass.
    std::vector<bool> allowed(set.places.size());
    for (std::size_t i = 0; i < allowed.size(); ++i) allowed[i] = eligible(set.places[i]);
    const std::vector<double> posterior = set.fabmap.posterior(
        query.words, placePrior(allowed, motion ? *motion : std::vector<double>{}, params_.fabmap));
    *new_place_probability = posterior.back();
    for (std::size_t i = 0; i < set.places.size(); ++i) {
      if (allowed[i] && shared[i] >= params_.min_correspondences &&
          posterior[i] >= params_.min_place_probability) {
        ranked.push_back({i, posterior[i], std::nullopt, 0});
      }
    }
    if (motion) *motion = posterior;
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const Ranked& a, const Ranked& b) { return a.score > b.score; });
  } else if (params_.method == MatchMethod::kScanContext) {
    if (!query.context) throw std::invalid_argument("a Scan Context query needs its descriptor");
    const auto matches = set.scan_context.query(
        *query.context, [&](std::size_t i) { return eligible(set.places[i]); });
    for (const auto& m : matches) ranked.push_back({m.index, 1.0 - m.distance.distance, {}});
  } else if (params_.method == MatchMethod::kHgmm) {
    ranked = rankByMixtures(set, query, eligible, query_is_from);
  } else {
    for (const auto& peak : set.histogram->candidates(query.scan.features.descriptors)) {
      if (eligible(set.places[peak.keyframe])) {
        ranked.push_back({peak.keyframe, static_cast<double>(peak.votes), {}});
      }
    }
  }
  for (Ranked& r : ranked) r.correspondences = shared[r.index];
  return ranked;
}

std::vector<MatchCandidate> PlaceMatcher::verify(PlaceSet& set, const DescribedKeyframe& query,
                                                 const std::vector<Ranked>& ranked,
                                                 bool query_is_from,
                                                 double new_place_probability) const {
  std::vector<MatchCandidate> candidates;
  for (const Ranked& r : ranked) {
    const DescribedKeyframe& place = set.places[r.index];
    MatchCandidate c;
    c.robot = set.robots[r.index];
    c.keyframe = place.id;
    c.score = r.score;
    c.new_place_probability = new_place_probability;
    c.correspondences = r.correspondences;
    const registration::PreparedScan& scan = ready(set, r.index);
    const registration::PreparedScan& from = query_is_from ? query.scan : scan;
    const registration::PreparedScan& to = query_is_from ? scan : query.scan;
    c.verification =
        r.initial ? verifier_.verifyFrom(from, to, *r.initial) : verifier_.verify(from, to);
    candidates.push_back(std::move(c));
  }
  return candidates;
}

std::vector<PlaceMatcher::Ranked> PlaceMatcher::rankByMixtures(
    const PlaceSet& set, const DescribedKeyframe& query,
    const std::function<bool(const DescribedKeyframe&)>& eligible, bool query_is_from) const {
  if (!query.mixture || !query.context) {
    throw std::invalid_argument("an hgmm query needs its mixture and Scan Context");
  }
  // Candidate places with the headings (of the place's levelled frame in the query's) that
  // registration starts from.
  std::vector<std::pair<std::size_t, std::vector<double>>> starts;
  if (params_.hgmm.candidates == MixtureCandidates::kScanContext) {
    for (const auto& m : set.scan_context.query(
             *query.context, [&](std::size_t i) { return eligible(set.places[i]); })) {
      starts.push_back({m.index, {m.distance.yaw_rad}});
    }
  } else {
    // GMM-to-GMM GICP converges from ~20 degrees off (gtest): 8 headings cover the circle.
    std::vector<double> headings;
    for (int k = 0; k < 8; ++k) headings.push_back(k * M_PI / 4.0);
    for (std::size_t i = 0; i < set.places.size(); ++i) {
      if (eligible(set.places[i])) starts.push_back({i, headings});
    }
  }
  std::vector<Ranked> ranked;
  for (const auto& [index, headings] : starts) {
    const DescribedKeyframe& place = set.places[index];
    if (!place.mixture || place.mixture->empty() || query.mixture->empty()) continue;
    // GICP moves "to" onto "from", each mixture in its levelled frame.
    const DescribedKeyframe& from = query_is_from ? query : place;
    const DescribedKeyframe& to = query_is_from ? place : query;
    std::optional<Ranked> best;
    for (const double heading : headings) {
      const double yaw = query_is_from ? heading : -heading;
      const Pose3 guess(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
      const hgmm::Registration r =
          hgmm::registerMixtures(*to.mixture, *from.mixture, guess, params_.hgmm.registration);
      if (!r.accepted || (best && r.similarity <= best->score)) continue;
      // The registered pose between the levelled frames, back in the sensor frames.
      const Pose3 initial = Pose3(Eigen::Quaterniond(from.level.transpose())) * r.transform *
                            Pose3(Eigen::Quaterniond(to.level));
      best = Ranked{index, r.similarity, initial};
    }
    if (best) ranked.push_back(*best);
  }
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const Ranked& a, const Ranked& b) { return a.score > b.score; });
  return ranked;
}

const DescribedKeyframe& PlaceMatcher::ownPlace(KeyframeId id) const {
  return own_->places[own_->index_of.at({std::string(), id})];
}

void PlaceMatcher::gateByOdometry(const DescribedKeyframe& query, MatchCandidate& c) const {
  const DescribedKeyframe& place = ownPlace(c.keyframe);
  if (!c.verification.accepted || !query.odom_pose || !place.odom_pose ||
      params_.own_loop_gate_m_per_m <= 0.0 || params_.own_loop_gate_rad_per_m <= 0.0) {
    return;
  }
  const Pose3 odometry = place.odom_pose->inverse() * *query.odom_pose;
  const Pose3 disagreement = odometry.inverse() * c.verification.relative;
  const double path_m = std::abs(query.path_m - place.path_m);
  const double shift_m = disagreement.translation().norm();
  const double turn_rad = Eigen::AngleAxisd(disagreement.linear()).angle();
  const double max_shift_m = PoseGate::kBaseAllowanceM + params_.own_loop_gate_m_per_m * path_m;
  const double max_turn_rad = 0.2 + params_.own_loop_gate_rad_per_m * path_m;
  if (shift_m > max_shift_m || turn_rad > max_turn_rad) {
    c.verification.accepted = false;
    c.verification.reason = "odometry disagrees by " + std::to_string(shift_m) + " m, " +
                            std::to_string(turn_rad) + " rad after " + std::to_string(path_m) +
                            " m (gate " + std::to_string(max_shift_m) + " m, " +
                            std::to_string(max_turn_rad) + " rad)";
  }
}

const DescribedKeyframe* PlaceMatcher::place(const PlaceSet& set, const std::string& robot,
                                             KeyframeId id) const {
  const auto it = set.index_of.find({robot, id});
  return it == set.index_of.end() ? nullptr : &set.places[it->second];
}

void PlaceMatcher::anchor(const std::string& robot, const DescribedKeyframe& own,
                          const DescribedKeyframe& other, const Pose3& relative) {
  if (!gateOn() || !own.odom_pose || !other.odom_pose) return;
  GateAnchor a;
  a.other_in_own = *own.odom_pose * relative * other.odom_pose->inverse();
  a.own_path_m = own.path_m;
  a.other_position = other.odom_pose->translation();
  if (robot.empty()) a.other_path_m = other.path_m;
  gate_.addAnchor(robot, a);
}

void PlaceMatcher::addTeammateClosure(const std::string& self,
                                      const pose_graph::LoopClosureData& loop) {
  // Ignored unless usable: a teammate's message may carry anything.
  if (loop.robot_to != self || loop.robot_from == self || !loop.odom_pose_from ||
      !isValidPose(*loop.odom_pose_from) || !isValidPose(loop.relative)) {
    return;
  }
  const DescribedKeyframe* own = place(*own_, "", loop.keyframe_to);
  if (!own) return;
  DescribedKeyframe theirs;
  theirs.odom_pose = loop.odom_pose_from;
  anchor(loop.robot_from, *own, theirs, loop.relative.inverse());
}

void PlaceMatcher::gateRatios(const PlaceSet& set, const std::string& robot,
                              const DescribedKeyframe& query, bool query_is_own,
                              std::vector<double>& gate) const {
  const auto positions = set.positions.find(query_is_own ? robot : std::string());
  if (!gateOn() || !query.odom_pose || positions == set.positions.end()) return;
  const GateKeyframe q{query.odom_pose->translation(),
                       query_is_own ? std::optional<double>(query.path_m) : std::nullopt};
  std::deque<GateAnchor> anchors = gate_.anchors(robot);
  // Own loops: odometry itself is a prior, anchored at the query.
  if (robot.empty()) anchors.push_back({Pose3::Identity(), query.path_m, q.position, q.path_m});
  // This robot's side of a pair and the other's: the places are the teammate's when this
  // robot's keyframe is the query.
  const bool places_are_other = query_is_own && !robot.empty();
  for (const GateAnchor& a : anchors) {
    // The query predicted in the places' frame.
    const Eigen::Vector3d centre =
        places_are_other ? a.other_in_own.inverse() * q.position : a.other_in_own * q.position;
    for (const std::size_t i : positions->second.within(centre, gate_.searchRadius())) {
      const DescribedKeyframe& p = set.places[i];
      const GateKeyframe place{p.odom_pose->translation(),
                               places_are_other ? std::nullopt : std::optional<double>(p.path_m)};
      const double r = places_are_other ? gate_.ratio(a, q, place) : gate_.ratio(a, place, q);
      gate[i] = std::min(gate[i], r);
    }
  }
}

std::vector<PlaceMatcher::Ranked> PlaceMatcher::nearestGated(
    const std::vector<Ranked>& ranked, const std::vector<double>& gate) const {
  std::vector<Ranked> gated;
  for (const Ranked& r : ranked) {
    if (gate[r.index] <= 1.0) gated.push_back(r);
  }
  // Within the gate the prior is a better guide than appearance, which an aliased mine fools.
  std::stable_sort(gated.begin(), gated.end(),
                   [&](const Ranked& a, const Ranked& b) { return gate[a.index] < gate[b.index]; });
  if (gated.size() > static_cast<std::size_t>(params_.search.gated_candidates)) {
    gated.resize(static_cast<std::size_t>(params_.search.gated_candidates));
  }
  return gated;
}

std::vector<MatchCandidate> PlaceMatcher::addOwn(DescribedKeyframe keyframe) {
  sawStamp(keyframe.stamp);
  const Stamp newest = keyframe.stamp - fromSeconds(params_.loop_exclusion_s);
  const bool gated = gateOn() && keyframe.odom_pose;
  std::vector<double> gate(own_->places.size(), gated ? kOutside : 0.0);
  gateRatios(*own_, "", keyframe, true, gate);
  double new_place_probability = -1.0;
  std::vector<Ranked> ranked = rank(
      *own_, keyframe,
      [&](const DescribedKeyframe& k) {
        // Places are held in a vector: k's address gives its index.
        return k.stamp <= newest && gate[&k - own_->places.data()] <= 1.0;
      },
      false, &own_posterior_, &new_place_probability);
  if (gated) {
    ranked = nearestGated(ranked, gate);
  } else if (ranked.size() > static_cast<std::size_t>(params_.max_candidates)) {
    ranked.resize(static_cast<std::size_t>(params_.max_candidates));
  }
  auto candidates = verify(*own_, keyframe, ranked, false, new_place_probability);
  for (auto& c : candidates) {
    gateByOdometry(keyframe, c);
    if (c.verification.accepted) {
      anchor("", ownPlace(c.keyframe), keyframe, c.verification.relative);
    }
  }
  own_->add("", std::move(keyframe));
  remember(*own_, own_->places.size() - 1);
  return candidates;
}

std::vector<MatchCandidate> PlaceMatcher::searchTeammates(
    PlaceSet& set, const DescribedKeyframe& query, const std::vector<Ranked>& ranked,
    const std::vector<double>& gate, bool query_is_from, double new_place_probability,
    const std::function<KeyframeId(const Ranked&)>& own_of,
    const std::function<std::pair<std::string, KeyframeId>(const Ranked&)>& teammate_of) {
  std::vector<Ranked> now = nearestGated(ranked, gate);
  std::size_t prior_free = 0;
  for (const Ranked& r : ranked) {
    if (gate[r.index] <= 1.0) continue;
    if (prior_free++ < static_cast<std::size_t>(params_.max_candidates)) {
      if (!queue_) {
        now.push_back(r);
        continue;
      }
      VerificationQueue::Entry e;
      e.rank = static_cast<int>(prior_free - 1);
      e.score = r.score;
      e.queued = newest_stamp_;
      e.own = own_of(r);
      std::tie(e.teammate, e.teammate_keyframe) = teammate_of(r);
      e.new_place_probability = new_place_probability;
      e.correspondences = r.correspondences;
      queue_->push(std::move(e));
    }
  }
  return verify(set, query, now, query_is_from, new_place_probability);
}

std::vector<MatchCandidate> PlaceMatcher::matchTeammate(const std::string& robot,
                                                        const DescribedKeyframe& keyframe) {
  sawStamp(keyframe.stamp);
  std::vector<double> gate(own_->places.size(), kOutside);
  gateRatios(*own_, robot, keyframe, false, gate);
  double new_place_probability = -1.0;
  const auto ranked = rank(
      *own_, keyframe, [](const DescribedKeyframe&) { return true; }, false, nullptr,
      &new_place_probability);
  auto candidates = searchTeammates(
      *own_, keyframe, ranked, gate, false, new_place_probability,
      [&](const Ranked& r) { return own_->places[r.index].id; },
      [&](const Ranked&) { return std::make_pair(robot, keyframe.id); });
  for (const auto& c : candidates) {
    if (c.verification.accepted) {
      anchor(robot, ownPlace(c.keyframe), keyframe, c.verification.relative);
    }
  }
  return candidates;
}

void PlaceMatcher::keepTeammateScan(const std::string& robot, DescribedKeyframe keyframe) {
  kept_->add(robot, std::move(keyframe));
  remember(*kept_, kept_->places.size() - 1);
}

std::vector<MatchCandidate> PlaceMatcher::matchKeptScans(const DescribedKeyframe& keyframe) {
  sawStamp(keyframe.stamp);
  std::vector<double> gate(kept_->places.size(), kOutside);
  for (const auto& [robot, positions] : kept_->positions) {
    gateRatios(*kept_, robot, keyframe, true, gate);
  }
  double new_place_probability = -1.0;
  const auto ranked = rank(
      *kept_, keyframe, [](const DescribedKeyframe&) { return true; }, true, nullptr,
      &new_place_probability);
  auto candidates = searchTeammates(
      *kept_, keyframe, ranked, gate, true, new_place_probability,
      [&](const Ranked&) { return keyframe.id; },
      [&](const Ranked& r) {
        return std::make_pair(kept_->robots[r.index], kept_->places[r.index].id);
      });
  for (const auto& c : candidates) {
    if (c.verification.accepted) {
      anchor(c.robot, keyframe, *place(*kept_, c.robot, c.keyframe), c.verification.relative);
    }
  }
  return candidates;
}

std::vector<PlaceMatcher::QueuedMatch> PlaceMatcher::verifyQueued() {
  std::vector<QueuedMatch> matches;
  if (!queue_) return matches;
  for (const auto& e : queue_->release(newest_stamp_)) {
    const auto own = own_->index_of.find({std::string(), e.own});
    const auto kept = kept_->index_of.find({e.teammate, e.teammate_keyframe});
    // Both are kept for good once matched; a pair whose own keyframe was never added (its
    // caller did not call addOwn) is skipped.
    if (own == own_->index_of.end() || kept == kept_->index_of.end()) continue;
    QueuedMatch m;
    m.own = e.own;
    m.waited_s = toSeconds(newest_stamp_ - e.queued);
    MatchCandidate& c = m.candidate;
    c.robot = e.teammate;
    c.keyframe = e.teammate_keyframe;
    c.score = e.score;
    c.new_place_probability = e.new_place_probability;
    c.correspondences = e.correspondences;
    // "from" is this robot's keyframe.
    const registration::PreparedScan& from = ready(*own_, own->second);
    c.verification = verifier_.verify(from, ready(*kept_, kept->second));
    if (c.verification.accepted) {
      anchor(e.teammate, own_->places[own->second], kept_->places[kept->second],
             c.verification.relative);
    }
    matches.push_back(std::move(m));
  }
  return matches;
}

const registration::PreparedScan& PlaceMatcher::ready(PlaceSet& set, std::size_t index) const {
  verifier_.complete(set.places[index].scan);
  remember(set, index);
  return set.places[index].scan;
}

void PlaceMatcher::remember(PlaceSet& set, std::size_t index) const {
  const std::pair<PlaceSet*, std::size_t> place{&set, index};
  const auto it = std::find(recent_.begin(), recent_.end(), place);
  if (it != recent_.end()) recent_.erase(it);
  recent_.push_back(place);
  while (recent_.size() > static_cast<std::size_t>(params_.complete_places)) {
    const auto [oldest_set, oldest] = recent_.front();
    registration::ScanVerifier::compact(oldest_set->places[oldest].scan);
    recent_.pop_front();
  }
}

}  // namespace ccir_mapping::core::place_recognition
