// eval_place_recognition: loop-closure detection between two robots of a simulated mission,
// against ground truth, through the Matcher's core (PlaceMatcher). Robot A's keyframes become
// places (its own loop closures are judged too), robot B's keyframes are the teammate's queries.
// A pair is true when the keyframes' true positions are within --true-distance-m. Prints JSON per
// method: TP/FP of each query's best-ranked place and of all verified candidates (thesis Table
// 4.1), then precision/recall of the best verified candidate per query, and after the team-frame
// EM the Backend runs on the verified inter-robot closures (poses from odometry, not ground
// truth); recall is over the truly overlapping queries. Per method also recall@1 and @5 (a true
// place among the first candidates) and precision-recall curves over the score of each query's
// best-ranked place and of its verified closure, with their average precision, and what the
// verification saw of each false closure.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include <boost/program_options.hpp>

#include "bag_keyframes.h"
#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/hgmm/novelty_keyframes.h"
#include "ccir_mapping/core/place_recognition/place_matcher.h"
#include "ccir_mapping/core/routing/scan_encoding.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace pr = core::place_recognition;
namespace tools = ccir_mapping::tools;

namespace {

struct Keyframe {
  core::Pose3 world_pose;  // true
  Eigen::Vector3d world_position;
  core::Pose3 odom_pose;
  /// Marginal covariance of odom_pose, [x y z, rotation vector], as a random walk along the path.
  core::Matrix6 odom_covariance;
  pr::DescribedKeyframe described;
};

/// Keyframes of one robot's bag, with true world positions from its ground-truth odometry.
using KeyframeCloud = pcl::PointCloud<pcl::PointXYZINormal>;

/// The keyframes of a robot's bag, described by `matcher` (and each handed to `on_keyframe`). With
/// `crossing`, each cloud first crosses the link in its scan_encoding (as a teammate's Broker
/// receives it) and its features are extracted from what arrives; `bytes` adds up the wire forms.
std::vector<Keyframe> keyframesOf(
    const std::string& bag_file, const core::Pose3& world_from_odom, double spacing_m,
    const Eigen::Vector2d& odom_noise_per_m, const pr::PlaceMatcher& matcher,
    const core::routing::BrokerParams* crossing = nullptr, std::size_t* bytes = nullptr,
    const std::function<void(const Keyframe&, const KeyframeCloud&)>& on_keyframe = {}) {
  BagKeyframeOptions options;
  options.truth_topic = "/ground_truth";
  options.keyframe_distance_m = spacing_m;
  const core::features::FeatureExtractor extractor(matcher.model().features);
  std::vector<Keyframe> keyframes;
  double path_m = 0.0;
  forEachBagKeyframe(bag_file, options, extractor, [&](BagKeyframe&& b) {
    Keyframe k;
    k.world_pose = world_from_odom * *b.true_pose;
    k.world_position = k.world_pose.translation();
    k.odom_pose = b.odom_pose;
    if (!keyframes.empty()) {
      path_m += (b.odom_pose.translation() - keyframes.back().odom_pose.translation()).norm();
    }
    k.odom_covariance.setZero();
    k.odom_covariance.diagonal().head<3>().setConstant(odom_noise_per_m.x() * odom_noise_per_m.x() *
                                                       path_m);
    k.odom_covariance.diagonal().tail<3>().setConstant(odom_noise_per_m.y() * odom_noise_per_m.y() *
                                                       path_m);
    if (crossing) {
      std::string error;
      const auto wire = core::routing::encodeKeyframeScan(*b.cloud, *crossing, &error);
      const auto cloud =
          wire ? core::routing::decodeKeyframeScan(*wire, crossing->scan_encoding, b.cloud->size(),
                                                   b.cloud->size(), keyframes.size(), &error)
               : std::nullopt;
      if (!cloud) throw std::runtime_error("a query scan does not cross the link: " + error);
      *bytes += wire->size();
      *b.cloud = *cloud;
      b.features = extractor.extract(*b.cloud, core::upInFrame(b.odom_pose));
    }
    k.described = matcher.describe(keyframes.size(), b.stamp, *b.cloud, std::move(b.features),
                                   core::upInFrame(b.odom_pose), crossing != nullptr);
    k.described.odom_pose = b.odom_pose;
    k.described.path_m = path_m;
    if (on_keyframe) on_keyframe(k, *b.cloud);
    keyframes.push_back(std::move(k));
  });
  return keyframes;
}

struct Counts {
  int tp = 0, fp = 0;
  /// Of the accepted closures, those whose relative pose is within 0.5 m and 3 degrees of the
  /// truth, whatever the distance between the keyframes.
  int correct_pose = 0;
  void add(bool truth) { (truth ? tp : fp)++; }
  double precision() const { return tp + fp ? double(tp) / (tp + fp) : 1.0; }
};

/// A query's answer judged against the truth: its score (FAB-MAP posterior, histogram votes).
struct Judged {
  double score = 0.0;
  bool truth = false;
};

/// Precision-recall over a score threshold: (recall, precision) from the highest score down,
/// recall over `overlapping` queries; and its average precision (the area, step-wise).
struct PrCurve {
  std::vector<std::pair<double, double>> points;
  double average_precision = 0.0;
};

PrCurve prCurve(std::vector<Judged> answers, int overlapping) {
  std::stable_sort(answers.begin(), answers.end(),
                   [](const Judged& a, const Judged& b) { return a.score > b.score; });
  PrCurve curve;
  int tp = 0, fp = 0;
  double recall_before = 0.0;
  for (std::size_t i = 0; i < answers.size(); ++i) {
    (answers[i].truth ? tp : fp)++;
    // Equal scores are one threshold.
    if (i + 1 < answers.size() && answers[i + 1].score == answers[i].score) continue;
    const double recall = overlapping ? double(tp) / overlapping : 0.0;
    const double precision = double(tp) / (tp + fp);
    curve.average_precision += precision * (recall - recall_before);
    recall_before = recall;
    curve.points.emplace_back(recall, precision);
  }
  return curve;
}

/// A verified closure the truth rejects, and what the verification saw.
struct FalseClosure {
  std::size_t query = 0, place = 0;
  double distance_m = 0.0, pose_error_m = 0.0, pose_error_deg = 0.0;
  core::registration::Verification verification;
};

struct MethodResult {
  Counts best_ranked, candidates, verified, team_frame, own_candidates, own_verified;
  /// Per query: the best-ranked place (before verification) and the closure verified.
  std::vector<Judged> best_ranked_scores, verified_scores;
  std::vector<FalseClosure> false_closures;
  /// Truly overlapping queries with a true place among the first 1 and 5 candidates.
  int true_in_top1 = 0, true_in_top5 = 0;
  /// The team transform's distance from the truth, when one was found.
  std::optional<core::Pose3> team_frame_error;
  /// The error left with exact loop-closure measurements (odometry drift alone).
  std::optional<core::Pose3> team_frame_drift_floor;
  /// Mean wall time of a teammate query (ranking and verification against every place).
  double ms_per_query = 0.0;
};

MethodResult evaluate(pr::MatchMethod method, const pr::MatcherParams& base,
                      const std::shared_ptr<const pr::PlaceModel>& model,
                      const std::vector<Keyframe>& map, const std::vector<Keyframe>& queries,
                      double true_distance_m, const core::Pose3& true_transform) {
  pr::MatcherParams params = base;
  params.method = method;
  // Each teammate query is judged on its own candidates: none wait for a verification budget.
  params.search.prior_free_verifications_per_s = 0.0;
  pr::PlaceMatcher matcher(params, model);
  MethodResult result;
  auto near = [&](const Keyframe& a, const Keyframe& b) {
    return (a.world_position - b.world_position).norm() <= true_distance_m;
  };
  for (const Keyframe& k : map) {
    const auto candidates = matcher.addOwn(k.described);
    for (const auto& c : candidates) result.own_candidates.add(near(map[c.keyframe], k));
    if (const auto* best = pr::bestAccepted(candidates)) {
      result.own_verified.add(near(map[best->keyframe], k));
    }
  }
  std::vector<core::alignment::AlignmentCandidate> closures;
  std::vector<bool> closure_true;
  std::vector<bool> closure_correct;
  std::vector<core::Pose3> closure_truth;
  double query_s = 0.0;
  for (const Keyframe& q : queries) {
    const auto start = std::chrono::steady_clock::now();
    const auto candidates = matcher.matchTeammate("teammate", q.described);
    query_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const bool truth = near(map[candidates[i].keyframe], q);
      result.candidates.add(truth);
      if (i == 0) {
        result.best_ranked.add(truth);
        result.best_ranked_scores.push_back({candidates[i].score, truth});
      }
      if (truth && i < 5) {
        result.true_in_top1 += i == 0;
        result.true_in_top5 +=
            std::none_of(candidates.begin(), candidates.begin() + i,
                         [&](const auto& c) { return near(map[c.keyframe], q); });
      }
    }
    const auto* best = pr::bestAccepted(candidates);
    if (!best) continue;
    const Keyframe& place = map[best->keyframe];
    result.verified.add(near(place, q));
    result.verified_scores.push_back({best->score, near(place, q)});
    const core::Pose3 error =
        (place.world_pose.inverse() * q.world_pose).inverse() * best->verification.relative;
    const bool correct = error.translation().norm() < 0.5 &&
                         Eigen::AngleAxisd(error.linear()).angle() < 3 * M_PI / 180;
    result.verified.correct_pose += correct;
    if (!near(place, q)) {
      result.false_closures.push_back(
          {std::size_t(&q - queries.data()), best->keyframe,
           (place.world_position - q.world_position).norm(), error.translation().norm(),
           Eigen::AngleAxisd(error.linear()).angle() * 180 / M_PI, best->verification});
    }
    core::alignment::AlignmentCandidate closure;
    closure.pose_a = place.odom_pose;
    closure.pose_b = q.odom_pose;
    closure.measurement = best->verification.relative;
    closure.covariance = best->verification.covariance;
    closure.covariance_a = place.odom_covariance;
    closure.covariance_b = q.odom_covariance;
    closures.push_back(closure);
    closure_true.push_back(near(place, q));
    closure_correct.push_back(correct);
    closure_truth.push_back(place.world_pose.inverse() * q.world_pose);
  }
  result.ms_per_query = 1e3 * query_s / std::max<std::size_t>(1, queries.size());
  const auto aligned =
      core::alignment::estimateFrameTransform(closures, core::alignment::AlignmentParams{});
  if (!aligned.found) return result;
  result.team_frame_error = true_transform.inverse() * aligned.transform;
  // The same inliers with exact relative poses: what is left is the odometry drift at the
  // closures, which no estimator of the transform between the start frames can remove.
  std::vector<core::alignment::AlignmentCandidate> exact;
  for (std::size_t k = 0; k < closures.size(); ++k) {
    if (!aligned.inliers[k]) continue;
    result.team_frame.add(closure_true[k]);
    result.team_frame.correct_pose += closure_correct[k];
    exact.push_back(closures[k]);
    exact.back().measurement = closure_truth[k];
  }
  core::alignment::AlignmentParams all_inliers;
  all_inliers.min_inliers = 1;
  all_inliers.min_inlier_margin = 0;
  all_inliers.inlier_prior = 0.99;
  const auto floor = core::alignment::estimateFrameTransform(exact, all_inliers);
  if (floor.found) result.team_frame_drift_floor = true_transform.inverse() * floor.transform;
  return result;
}

struct Options {
  std::string mission_dir;
  std::string model_dir;
  double spacing_m = 2.0;
  double true_distance_m = 3.0;
  Eigen::Vector2d odom_noise_per_m{0.02, 0.005};
  std::vector<pr::MatchMethod> methods;
  pr::MatcherParams params;
  /// How robot B's scans (the queries) reach robot A.
  core::routing::BrokerParams crossing;
};

/// Robot B's scans, with --query-encoding gmm (cloud: as recorded).
bool crossesAsMixture(const Options& o, int robot) {
  return robot == 1 && o.crossing.scan_encoding == core::routing::ScanEncoding::kGmm;
}

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  pr::MatcherParams& params = o->params;
  std::string methods = "fabmap,histogram,scan_context,hgmm";
  std::string hgmm_candidates = pr::toString(params.hgmm.candidates);
  std::string query_encoding = core::routing::toString(o->crossing.scan_encoding);
  po::options_description options(
      "Usage: eval_place_recognition --mission DIR --model DIR [options]\nPrints JSON.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "mission", po::value<std::string>(&o->mission_dir), "simulate_team output (two robots used)")(
      "model", po::value<std::string>(&o->model_dir), "train_place_model output")(
      "methods", po::value<std::string>(&methods)->default_value(methods),
      "comma-separated methods to evaluate")(
      "keyframe-distance-m", po::value<double>(&o->spacing_m)->default_value(o->spacing_m),
      "odometry travel between keyframes [m]")(
      "true-distance-m", po::value<double>(&o->true_distance_m)->default_value(o->true_distance_m),
      "a candidate is true within this true distance [m]")(
      "candidates", po::value<int>(&params.max_candidates)->default_value(params.max_candidates),
      "best-ranked places of each query that are verified")(
      "min-place-probability",
      po::value<double>(&params.min_place_probability)->default_value(params.min_place_probability),
      "FAB-MAP: only candidates with at least this posterior are verified")(
      "new-place-prior",
      po::value<double>(&params.fabmap.new_place_prior)
          ->default_value(params.fabmap.new_place_prior),
      "FAB-MAP: prior probability of a new place")(
      "motion-prior-weight",
      po::value<double>(&params.fabmap.motion_prior_weight)
          ->default_value(params.fabmap.motion_prior_weight),
      "FAB-MAP: share of the places' prior following the previous own query's posterior")(
      "min-correspondences",
      po::value<int>(&params.min_correspondences)->default_value(params.min_correspondences),
      "c_k,min: shared words (FAB-MAP) or votes (histogram) a candidate needs")(
      "min-inliers",
      po::value<int>(&params.verification.min_inliers)
          ->default_value(params.verification.min_inliers),
      "verification: keypoints agreeing on the transform")(
      "min-overlap",
      po::value<double>(&params.verification.min_overlap)
          ->default_value(params.verification.min_overlap),
      "verification: wall overlap")("overlap-distance-m",
                                    po::value<double>(&params.verification.overlap_distance_m)
                                        ->default_value(params.verification.overlap_distance_m),
                                    "verification: wall points closer than this overlap [m]")(
      "max-free-space-violation",
      po::value<double>(&params.verification.max_free_space_violation)
          ->default_value(params.verification.max_free_space_violation),
      "verification: share of wall points where the other scan saw free space")(
      "free-space-margin-m",
      po::value<double>(&params.verification.free_space_margin_m)
          ->default_value(params.verification.free_space_margin_m),
      "verification: ... beyond this margin [m]")(
      "mixture-overlap-distance-m",
      po::value<double>(&params.verification.mixture_overlap_distance_m)
          ->default_value(params.verification.mixture_overlap_distance_m),
      "verification with a query drawn from its mixture: overlap distance [m]")(
      "mixture-free-space-margin-m",
      po::value<double>(&params.verification.mixture_free_space_margin_m)
          ->default_value(params.verification.mixture_free_space_margin_m),
      "... and free-space margin [m]")(
      "loop-exclusion-s",
      po::value<double>(&params.loop_exclusion_s)->default_value(params.loop_exclusion_s),
      "robot A's own keyframes younger than this are not matched [s]")(
      "hgmm-candidates", po::value<std::string>(&hgmm_candidates)->default_value(hgmm_candidates),
      "hgmm: places registered (scan_context | all)")(
      "hgmm-max-depth",
      po::value<int>(&params.hgmm.model.max_depth)->default_value(params.hgmm.model.max_depth),
      "hgmm: levels below the root; the deepest is registered")(
      "hgmm-min-similarity",
      po::value<double>(&params.hgmm.registration.min_similarity)
          ->default_value(params.hgmm.registration.min_similarity),
      "hgmm: registered mixtures less similar are no candidates")(
      "query-encoding", po::value<std::string>(&query_encoding)->default_value(query_encoding),
      "how the queries cross the link (the Broker's scan_encoding): cloud (as recorded) | gmm "
      "(described from the points drawn from their mixtures)")(
      "gmm-max-bytes",
      po::value<int>(&o->crossing.gmm_max_bytes)->default_value(o->crossing.gmm_max_bytes),
      "gmm: most bytes of a query's mixture")(
      "odom-noise-m-per-m", po::value<double>(&o->odom_noise_per_m.x())->default_value(0.02),
      "odometry position noise (std per axis per sqrt(m) travelled; simulate_team's default)")(
      "odom-noise-rad-per-m", po::value<double>(&o->odom_noise_per_m.y())->default_value(0.005),
      "odometry heading noise (std per sqrt(m) travelled)");
  if (const auto exit_code =
          tools::parseCommandLine("eval_place_recognition", options, argc, argv)) {
    return exit_code;
  }
  auto errors = params.validate();
  const auto candidates = pr::parseMixtureCandidates(hgmm_candidates);
  if (!candidates) errors.push_back("--hgmm-candidates: one of scan_context | all");
  params.hgmm.candidates = candidates.value_or(params.hgmm.candidates);
  const auto encoding = core::routing::parseScanEncoding(query_encoding);
  if (!encoding) errors.push_back("--query-encoding: one of cloud | gmm");
  o->crossing.scan_encoding = encoding.value_or(o->crossing.scan_encoding);
  const auto more = o->crossing.validate();
  errors.insert(errors.end(), more.begin(), more.end());
  std::stringstream list(methods);
  for (std::string name; std::getline(list, name, ',');) {
    const auto method = pr::parseMatchMethod(name);
    if (!method)
      errors.push_back("--methods: '" + name + "' is not one of " +
                       std::string(pr::kMatchMethodChoices));
    if (method) o->methods.push_back(*method);
  }
  if (o->methods.empty()) errors.push_back("--methods: none given");
  if (!errors.empty() || o->mission_dir.empty() || o->model_dir.empty() || !(o->spacing_m > 0) ||
      !(o->true_distance_m > 0)) {
    return tools::usageError(
        "eval_place_recognition",
        errors.empty() ? "need --mission and --model (see --help)" : errors.front());
  }
  return std::nullopt;
}

struct Results {
  std::size_t map_keyframes = 0, query_keyframes = 0;
  int overlapping = 0;
  double words_per_keyframe = 0.0;
  /// Reading the bags, features, words, Scan Context and (with hgmm) the mixture; with
  /// --query-encoding gmm also the queries' crossing; not the novelty store.
  double describe_ms_per_keyframe = 0.0;
  /// Mean wire form of a query scan (--query-encoding).
  double query_scan_bytes = 0.0;
  /// With hgmm: robot A's keyframes offered to the HGMM novelty store (thesis 6.2), those it
  /// stored, its bytes, the points' bytes (x y z float32) and the ground they cover (1 m cells
  /// of the world's x y holding a point).
  struct Store {
    std::size_t offered = 0, stored = 0, bytes = 0, cloud_bytes = 0, mapped_m2 = 0;
  };
  std::optional<Store> store;
  std::vector<std::pair<pr::MatchMethod, MethodResult>> methods;
};

/// Throws std::runtime_error (the mission or model cannot be read, fewer than two robots).
Results run(const Options& o) {
  const auto model = pr::PlaceModel::load(o.model_dir);
  const std::vector<MissionBag> bags = missionBags(o.mission_dir);
  if (bags.size() < 2) throw std::runtime_error("the mission needs two robots");
  // Described once for every method: with Scan Context's descriptor (and the mixture when hgmm is
  // evaluated), which the others ignore.
  pr::MatcherParams describe_params = o.params;
  const bool hgmm = std::count(o.methods.begin(), o.methods.end(), pr::MatchMethod::kHgmm) > 0;
  describe_params.method = hgmm ? pr::MatchMethod::kHgmm : pr::MatchMethod::kScanContext;
  const pr::PlaceMatcher describer(describe_params, model);
  std::vector<std::vector<Keyframe>> robots;
  const auto start = std::chrono::steady_clock::now();
  std::size_t query_bytes = 0;
  Results results;
  core::hgmm::NoveltyKeyframes store{core::hgmm::NoveltyParams{}};
  std::set<std::pair<long, long>> cells;
  double store_s = 0.0;
  auto toStore = [&](const Keyframe& k, const KeyframeCloud& cloud) {
    const auto store_start = std::chrono::steady_clock::now();
    core::hgmm::Points points(3, static_cast<Eigen::Index>(cloud.size()));
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
      points.col(static_cast<Eigen::Index>(i)) = p;
      const Eigen::Vector3d w = k.world_pose * p;
      cells.emplace(std::lround(std::floor(w.x())), std::lround(std::floor(w.y())));
    }
    auto& s = *results.store;
    ++s.offered;
    s.stored += store.offer(points, k.world_pose);
    s.cloud_bytes += 12 * cloud.size();
    store_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - store_start).count();
  };
  if (hgmm) results.store.emplace();
  for (int r = 0; r < 2; ++r) {
    robots.push_back(keyframesOf(
        bags[r].path, bags[r].world_from_odom, o.spacing_m, o.odom_noise_per_m, describer,
        crossesAsMixture(o, r) ? &o.crossing : nullptr, &query_bytes,
        hgmm && r == 0 ? std::function<void(const Keyframe&, const KeyframeCloud&)>(toStore)
                       : nullptr));
  }
  if (results.store) {
    results.store->bytes = store.bytes();
    results.store->mapped_m2 = cells.size();
  }
  const double describe_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - store_s;
  const auto& map = robots[0];
  const auto& queries = robots[1];
  results.map_keyframes = map.size();
  results.query_keyframes = queries.size();
  results.query_scan_bytes = double(query_bytes) / std::max<std::size_t>(1, queries.size());
  for (const Keyframe& q : queries) {
    results.overlapping += std::any_of(map.begin(), map.end(), [&](const Keyframe& m) {
      return (q.world_position - m.world_position).norm() <= o.true_distance_m;
    });
  }
  double words = 0;
  for (const auto& robot : robots) {
    for (const auto& k : robot) words += k.described.words.size();
  }
  results.words_per_keyframe = words / std::max<std::size_t>(1, map.size() + queries.size());
  results.describe_ms_per_keyframe =
      1e3 * describe_s / std::max<std::size_t>(1, map.size() + queries.size());
  for (const pr::MatchMethod method : o.methods) {
    results.methods.emplace_back(
        method, evaluate(method, o.params, model, map, queries, o.true_distance_m,
                         bags[0].world_from_odom.inverse() * bags[1].world_from_odom));
  }
  return results;
}

void report(const Options& o, const Results& results) {
  std::printf(
      "{\n  \"benchmark\": \"place_recognition_eval\",\n  \"mission\": \"%s\",\n"
      "  \"map_keyframes\": %zu,\n  \"query_keyframes\": %zu,\n"
      "  \"overlapping_queries\": %d,\n  \"words_per_keyframe\": %.1f,\n"
      "  \"candidates_per_query\": %d,\n  \"describe_ms_per_keyframe\": %.1f,\n"
      "  \"query_encoding\": \"%s\",\n  \"query_scan_bytes\": %.0f,\n",
      o.mission_dir.c_str(), results.map_keyframes, results.query_keyframes, results.overlapping,
      results.words_per_keyframe, o.params.max_candidates, results.describe_ms_per_keyframe,
      core::routing::toString(o.crossing.scan_encoding), results.query_scan_bytes);
  if (const auto& s = results.store) {
    const double m2 = double(std::max<std::size_t>(1, s->mapped_m2));
    std::printf(
        "  \"hgmm_store\": {\"offered\": %zu, \"stored\": %zu, \"bytes\": %zu, \"mapped_m2\": %zu, "
        "\"bytes_per_m2\": %.1f, \"cloud_bytes_per_m2\": %.1f},\n",
        s->offered, s->stored, s->bytes, s->mapped_m2, s->bytes / m2, s->cloud_bytes / m2);
  }
  std::printf("  \"methods\": {\n");
  const int overlapping = results.overlapping;
  for (const auto& [method, r] : results.methods) {
    auto stage = [&](const char* name, const Counts& c, const char* end) {
      std::printf(
          "      \"%s\": {\"tp\": %d, \"fp\": %d, \"precision\": %.3f, \"recall\": %.3f, "
          "\"correct_pose\": %d}%s\n",
          name, c.tp, c.fp, c.precision(), overlapping ? double(c.tp) / overlapping : 0.0,
          c.correct_pose, end);
    };
    std::printf(
        "    \"%s\": {\n      \"best_ranked_tp\": %d, \"best_ranked_fp\": %d, "
        "\"candidates_tp\": %d, \"candidates_fp\": %d,\n",
        pr::toString(method), r.best_ranked.tp, r.best_ranked.fp, r.candidates.tp, r.candidates.fp);
    stage("verified", r.verified, ",");
    stage("team_frame", r.team_frame, ",");
    std::printf("      \"recall_at_1\": %.3f, \"recall_at_5\": %.3f, \"ms_per_query\": %.1f,\n",
                overlapping ? double(r.true_in_top1) / overlapping : 0.0,
                overlapping ? double(r.true_in_top5) / overlapping : 0.0, r.ms_per_query);
    for (const auto& [name, answers] :
         {std::pair{"best_ranked", &r.best_ranked_scores}, {"verified", &r.verified_scores}}) {
      const PrCurve curve = prCurve(*answers, overlapping);
      std::printf("      \"pr_%s\": {\"average_precision\": %.3f, \"recall_precision\": [", name,
                  curve.average_precision);
      for (std::size_t i = 0; i < curve.points.size(); ++i) {
        std::printf("%s[%.4f, %.4f]", i ? ", " : "", curve.points[i].first, curve.points[i].second);
      }
      std::printf("]},\n");
    }
    auto error = [](const char* name, const std::optional<core::Pose3>& e) {
      if (!e) return;
      std::printf("      \"%s\": {\"m\": %.3f, \"deg\": %.2f},\n", name, e->translation().norm(),
                  Eigen::AngleAxisd(e->linear()).angle() * 180 / M_PI);
    };
    std::printf("      \"false_closures\": [");
    for (std::size_t i = 0; i < r.false_closures.size(); ++i) {
      const FalseClosure& f = r.false_closures[i];
      std::printf(
          "%s{\"query\": %zu, \"place\": %zu, \"distance_m\": %.1f, \"pose_error_m\": %.2f, "
          "\"pose_error_deg\": %.1f, \"inliers\": %d, \"fitness_m2\": %.3f, \"overlap\": %.3f, "
          "\"free_space_violation\": %.4f}",
          i ? ", " : "", f.query, f.place, f.distance_m, f.pose_error_m, f.pose_error_deg,
          f.verification.inliers, f.verification.fitness_m2, f.verification.overlap,
          f.verification.free_space_violation);
    }
    std::printf("],\n");
    error("team_frame_error", r.team_frame_error);
    error("team_frame_drift_floor", r.team_frame_drift_floor);
    std::printf(
        "      \"own_loops\": {\"candidates_tp\": %d, \"candidates_fp\": %d, \"verified_tp\": "
        "%d, \"verified_fp\": %d}\n    }%s\n",
        r.own_candidates.tp, r.own_candidates.fp, r.own_verified.tp, r.own_verified.fp,
        &r == &results.methods.back().second ? "" : ",");
  }
  std::printf("  }\n}\n");
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("eval_place_recognition", argc, argv, parse, run, report);
}
