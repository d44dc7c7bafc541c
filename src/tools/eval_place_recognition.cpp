// eval_place_recognition: place recognition between two robots of a simulated mission, against
// ground truth. Robot A's keyframes are the map, robot B's the queries; a candidate is true when
// the two keyframes' true positions are within --true-distance-m. Prints JSON: candidate TP/FP of
// FAB-MAP 2.0 and of the histogram baseline (thesis Table 4.1); precision/recall after geometric
// verification (the best verified of each query's candidates) and after the team-frame EM the
// Backend runs on verified inter-robot closures (poses from odometry, not ground truth), over the
// truly overlapping queries.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include <yaml-cpp/yaml.h>
#include <boost/program_options.hpp>

#include "bag_keyframes.h"
#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/histogram_matcher.h"
#include "ccir_mapping/core/registration/scan_verifier.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace pr = core::place_recognition;
namespace fs = std::filesystem;

namespace {

struct Keyframe {
  core::Stamp stamp;
  Eigen::Vector3d world_position;
  core::Pose3 odom_pose;
  /// Marginal covariance of odom_pose, [x y z, rotation vector], as a random walk along the path.
  core::alignment::Matrix6 odom_covariance;
  core::preprocess::ScanPreprocessor::OutputCloud::Ptr cloud;
  core::features::LocalFeatures features;
  pr::WordSet words;
};

core::Pose3 poseFromYaml(const YAML::Node& p) {
  core::Pose3 pose = core::Pose3::Identity();
  pose.translation() << p["x"].as<double>(), p["y"].as<double>(), p["z"].as<double>();
  pose.linear() = Eigen::Quaterniond(p["qw"].as<double>(), p["qx"].as<double>(),
                                     p["qy"].as<double>(), p["qz"].as<double>())
                      .normalized()
                      .toRotationMatrix();
  return pose;
}

/// Keyframes of one robot's bag, with true world positions from its ground-truth odometry.
std::vector<Keyframe> keyframesOf(const fs::path& bag_file, const core::Pose3& world_from_odom,
                                  double spacing_m, const Eigen::Vector2d& odom_noise_per_m,
                                  const pr::Vocabulary& vocabulary,
                                  const core::features::FeatureExtractor& extractor) {
  BagKeyframeOptions options;
  options.truth_topic = "/ground_truth";
  options.keyframe_distance_m = spacing_m;
  std::vector<Keyframe> keyframes;
  double path_m = 0.0;
  forEachBagKeyframe(bag_file.string(), options, extractor, [&](BagKeyframe&& b) {
    Keyframe k;
    k.stamp = b.stamp;
    k.odom_pose = b.odom_pose;
    path_m += keyframes.empty()
                  ? 0.0
                  : (b.odom_pose.translation() - keyframes.back().odom_pose.translation()).norm();
    k.odom_covariance.setZero();
    k.odom_covariance.diagonal().head<3>().setConstant(odom_noise_per_m.x() * odom_noise_per_m.x() *
                                                       path_m);
    k.odom_covariance.diagonal().tail<3>().setConstant(odom_noise_per_m.y() * odom_noise_per_m.y() *
                                                       path_m);
    k.world_position = (world_from_odom * *b.true_pose).translation();
    k.cloud = std::move(b.cloud);
    k.words = vocabulary.quantize(b.features.descriptors);
    k.features = std::move(b.features);
    keyframes.push_back(std::move(k));
  });
  return keyframes;
}

std::vector<pr::WordSet> readSamples(const fs::path& path, const std::string& hash) {
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line) || line.find(hash) == std::string::npos) {
    throw std::runtime_error(path.string() + " is missing or not for vocabulary " + hash);
  }
  std::vector<pr::WordSet> samples;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    pr::WordSet set;
    for (std::uint32_t w; words >> w;) set.push_back(w);
    samples.push_back(set);
  }
  return samples;
}

}  // namespace

int main(int argc, char** argv) {
  std::string mission_dir;
  std::string model_dir;
  double spacing_m = 2.0;
  double true_distance_m = 3.0;
  double min_posterior = 0.0;
  int min_votes = 1;
  int max_candidates = 20;
  Eigen::Vector2d odom_noise_per_m(0.02, 0.005);
  core::features::FeatureParams feature_params;
  std::string drop_horizontal = core::preprocess::toString(feature_params.drop_horizontal);
  po::options_description options(
      "Usage: eval_place_recognition --mission DIR --model DIR [options]\nPrints JSON.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "mission", po::value<std::string>(&mission_dir), "simulate_team output (two robots used)")(
      "model", po::value<std::string>(&model_dir), "train_place_model output")(
      "keyframe-distance-m", po::value<double>(&spacing_m)->default_value(spacing_m),
      "odometry travel between keyframes [m]")(
      "true-distance-m", po::value<double>(&true_distance_m)->default_value(true_distance_m),
      "a candidate is true within this true distance [m]")(
      "min-posterior", po::value<double>(&min_posterior)->default_value(min_posterior),
      "FAB-MAP posterior a candidate needs")(
      "odom-noise-m-per-m", po::value<double>(&odom_noise_per_m.x())->default_value(0.02),
      "odometry position noise (std per axis per sqrt(m) travelled; simulate_team's default)")(
      "odom-noise-rad-per-m", po::value<double>(&odom_noise_per_m.y())->default_value(0.005),
      "odometry heading noise (std per sqrt(m) travelled)")(
      "candidates", po::value<int>(&max_candidates)->default_value(max_candidates),
      "best places of each query that are verified")(
      "min-votes", po::value<int>(&min_votes)->default_value(min_votes),
      "histogram votes a candidate needs")(
      "feature-drop-horizontal",
      po::value<std::string>(&drop_horizontal)->default_value(drop_horizontal),
      "degenerate-normal filter of the features: none | ground | ceiling | both (as in training)")(
      "iss-non-max-radius-m",
      po::value<double>(&feature_params.iss_non_max_radius_m)
          ->default_value(feature_params.iss_non_max_radius_m),
      "ISS non-maximum suppression radius (as in training) [m]");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "eval_place_recognition: " << e.what() << '\n';
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  const auto filter = core::preprocess::parseHorizontalFilter(drop_horizontal);
  if (filter) feature_params.drop_horizontal = *filter;
  if (!filter || !feature_params.validate().empty() || mission_dir.empty() || model_dir.empty() ||
      !(spacing_m > 0) || !(true_distance_m > 0) || max_candidates < 1) {
    std::cerr << "eval_place_recognition: need --mission and --model (see --help)\n";
    return 2;
  }
  try {
    const pr::Vocabulary vocabulary =
        pr::Vocabulary::load((fs::path(model_dir) / "vocabulary.bin").string());
    const pr::ChowLiuTree tree = pr::ChowLiuTree::load(
        (fs::path(model_dir) / "chow_liu_tree.txt").string(), vocabulary.hash());
    const auto samples = readSamples(fs::path(model_dir) / "samples.txt", vocabulary.hash());
    const YAML::Node mission = YAML::LoadFile((fs::path(mission_dir) / "mission.yaml").string());
    if (mission["robots"].size() < 2) throw std::runtime_error("the mission needs two robots");
    const core::features::FeatureExtractor extractor(feature_params);
    std::vector<std::vector<Keyframe>> robots;
    for (int r = 0; r < 2; ++r) {
      const YAML::Node robot = mission["robots"][r];
      robots.push_back(keyframesOf(fs::path(mission_dir) / robot["bag"].as<std::string>(),
                                   poseFromYaml(robot["initial_pose_in_world"]), spacing_m,
                                   odom_noise_per_m, vocabulary, extractor));
    }
    const auto& map = robots[0];
    const auto& queries = robots[1];

    const pr::FabMapModel model(tree, pr::FabMapParams{});
    pr::FabMap2 fabmap(model, samples);
    pr::HistogramParams histogram_params;
    histogram_params.min_votes = min_votes;
    pr::HistogramMatcher histogram(histogram_params);
    for (std::size_t i = 0; i < map.size(); ++i) {
      fabmap.addPlace(map[i].words);
      histogram.addKeyframe(i, map[i].features.descriptors);
    }
    const core::registration::ScanVerifier verifier{core::registration::VerificationParams{}};
    struct Count {
      int tp = 0, fp = 0, verified_tp = 0, verified_fp = 0, aligned_tp = 0, aligned_fp = 0;
      std::vector<core::alignment::AlignmentCandidate> closures;
      std::vector<bool> closure_true;
    } fab, hist;
    int overlapping = 0;
    auto near = [&](const Keyframe& a, const Keyframe& b) {
      return (a.world_position - b.world_position).norm() <= true_distance_m;
    };
    for (const Keyframe& q : queries) {
      bool overlaps = false;
      for (const Keyframe& m : map) overlaps = overlaps || near(q, m);
      overlapping += overlaps;
      // Verifies each candidate place; the one with most inliers is the query's loop closure.
      auto judge = [&](const std::vector<std::size_t>& places, Count& count) {
        std::optional<core::registration::Verification> best;
        std::size_t best_place = 0;
        for (const std::size_t place : places) {
          (near(q, map[place]) ? count.tp : count.fp)++;
          const auto v =
              verifier.verify(*map[place].cloud, map[place].features, *q.cloud, q.features);
          if (v.accepted && (!best || v.inliers > best->inliers)) {
            best = v;
            best_place = place;
          }
        }
        if (!best) return;
        const bool truth = near(q, map[best_place]);
        (truth ? count.verified_tp : count.verified_fp)++;
        core::alignment::AlignmentCandidate closure;
        closure.pose_a = map[best_place].odom_pose;
        closure.pose_b = q.odom_pose;
        closure.measurement = best->relative;
        closure.covariance = best->covariance;
        closure.covariance_a = map[best_place].odom_covariance;
        closure.covariance_b = q.odom_covariance;
        count.closures.push_back(closure);
        count.closure_true.push_back(truth);
      };
      const auto posterior = fabmap.posterior(q.words);
      std::vector<std::size_t> places;
      for (std::size_t i = 0; i < map.size(); ++i) {
        if (posterior[i] >= min_posterior) places.push_back(i);
      }
      std::sort(places.begin(), places.end(),
                [&](std::size_t a, std::size_t b) { return posterior[a] > posterior[b]; });
      places.resize(std::min<std::size_t>(places.size(), max_candidates));
      judge(places, fab);
      places.clear();
      for (const auto& peak : histogram.candidates(q.features.descriptors)) {
        if (places.size() < static_cast<std::size_t>(max_candidates)) {
          places.push_back(static_cast<std::size_t>(peak.keyframe));
        }
      }
      judge(places, hist);
    }
    for (Count* count : {&fab, &hist}) {
      const auto aligned = core::alignment::estimateFrameTransform(
          count->closures, core::alignment::AlignmentParams{});
      for (std::size_t k = 0; aligned.found && k < count->closures.size(); ++k) {
        if (aligned.inliers[k]) (count->closure_true[k] ? count->aligned_tp : count->aligned_fp)++;
      }
    }
    auto report = [&](const char* name, const Count& c, bool last) {
      auto precision = [](int tp, int fp) { return tp + fp ? double(tp) / (tp + fp) : 1.0; };
      auto recall = [&](int tp) { return overlapping ? double(tp) / overlapping : 0.0; };
      std::printf(
          "    \"%s\": {\"candidates_tp\": %d, \"candidates_fp\": %d,\n"
          "      \"verified\": {\"tp\": %d, \"fp\": %d, \"precision\": %.3f, \"recall\": %.3f},\n"
          "      \"team_frame\": {\"tp\": %d, \"fp\": %d, \"precision\": %.3f, \"recall\": "
          "%.3f}}%s\n",
          name, c.tp, c.fp, c.verified_tp, c.verified_fp, precision(c.verified_tp, c.verified_fp),
          recall(c.verified_tp), c.aligned_tp, c.aligned_fp, precision(c.aligned_tp, c.aligned_fp),
          recall(c.aligned_tp), last ? "" : ",");
    };
    double words = 0;
    for (const auto& robot : robots) {
      for (const auto& k : robot) words += k.words.size();
    }
    std::printf(
        "{\n  \"benchmark\": \"place_recognition_eval\",\n  \"mission\": \"%s\",\n"
        "  \"map_keyframes\": %zu,\n  \"query_keyframes\": %zu,\n"
        "  \"overlapping_queries\": %d,\n  \"words_per_keyframe\": %.1f,\n  \"methods\": {\n",
        mission_dir.c_str(), map.size(), queries.size(), overlapping,
        words / std::max<std::size_t>(1, map.size() + queries.size()));
    report("fabmap", fab, false);
    report("histogram", hist, true);
    std::printf("  }\n}\n");
  } catch (const std::exception& e) {
    std::cerr << "eval_place_recognition: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
