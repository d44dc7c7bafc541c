// eval_features: the feature study. Per keyframe of simulated missions (--mission, every robot)
// and of real scans (--pcd): points on the feature grid, ISS keypoints, spin images, and with
// --model the words they quantise to. On the missions also the keypoints' repeatability at
// revisits (keyframes within --revisit-distance-m of each other, taken --revisit-gap-s apart or
// by different robots): of a keyframe's keypoints within the feature range of the other
// keyframe's sensor, the share with one of its keypoints within --repeat-distance-m under the true
// relative pose; and the same for as many points drawn at random from each keyframe cloud (within
// the feature range), the share that chance alone gives at that density. Prints JSON. Exit codes: 0
// done, 1 cannot read, 2 bad arguments.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <random>

#include <pcl/io/pcd_io.h>
#include <boost/program_options.hpp>

#include "bag_keyframes.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "command_line.h"
#include "feature_options.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace tools = ccir_mapping::tools;

namespace {

struct Options {
  std::vector<std::string> missions;
  std::vector<std::string> pcds;
  std::string model_dir;
  double keyframe_distance_m = 2.0;
  double revisit_distance_m = 2.0;
  double revisit_gap_s = 30.0;
  double repeat_distance_m = 0.5;
  core::features::FeatureParams features;
};

std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: eval_features [--mission DIR ...] [--pcd FILE ...] [--model DIR] [feature flags]\n"
      "With --model the features are the model's and the feature flags are refused.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "mission", po::value<std::vector<std::string>>(&o->missions)->multitoken(),
      "simulate_team outputs")("pcd", po::value<std::vector<std::string>>(&o->pcds)->multitoken(),
                               "real scans (x y z intensity)")(
      "model", po::value<std::string>(&o->model_dir), "train_place_model output: words too")(
      "keyframe-distance-m",
      po::value<double>(&o->keyframe_distance_m)->default_value(o->keyframe_distance_m),
      "odometry travel between keyframes [m]")(
      "revisit-distance-m",
      po::value<double>(&o->revisit_distance_m)->default_value(o->revisit_distance_m),
      "keyframes this close (true positions) are a revisit [m]")(
      "revisit-gap-s", po::value<double>(&o->revisit_gap_s)->default_value(o->revisit_gap_s),
      "... when one robot took them at least this far apart [s]")(
      "repeat-distance-m",
      po::value<double>(&o->repeat_distance_m)->default_value(o->repeat_distance_m),
      "a keypoint repeats when the revisit has one this close [m]");
  const tools::FeatureOptions features(&options, &o->features);
  po::variables_map parsed;
  if (const auto exit_code =
          tools::parseCommandLine("eval_features", options, argc, argv, &parsed)) {
    return exit_code;
  }
  if (const std::string error = features.apply(); !error.empty()) {
    return tools::usageError("eval_features", error);
  }
  const bool feature_flag = std::any_of(parsed.begin(), parsed.end(), [](const auto& entry) {
    return !entry.second.defaulted() &&
           (entry.first.rfind("feature-", 0) == 0 || entry.first.rfind("iss-", 0) == 0 ||
            entry.first.rfind("spin-", 0) == 0);
  });
  if ((o->missions.empty() && o->pcds.empty()) || (feature_flag && !o->model_dir.empty()) ||
      !(o->keyframe_distance_m > 0) || !(o->revisit_distance_m > 0) ||
      !(o->repeat_distance_m > 0)) {
    return tools::usageError("eval_features",
                             "need --mission or --pcd, positive distances, and no feature flag "
                             "with --model");
  }
  return std::nullopt;
}

struct Counts {
  std::vector<double> points, keypoints, descriptors, words;
  void add(const core::features::ExtractionStats& s, std::optional<std::size_t> word_count) {
    points.push_back(double(s.points));
    keypoints.push_back(double(s.keypoints));
    descriptors.push_back(double(s.descriptors));
    if (word_count) words.push_back(double(*word_count));
  }
};

struct Source {
  std::string name;
  Counts counts;
  int revisits = 0;
  double repeatability = 0.0;  // mean over both directions of every revisit
  double chance = 0.0;         // the same for random points of the keyframes
};

struct Results {
  core::features::FeatureParams features;
  std::vector<Source> sources;
};

/// Share of `a`'s keypoints (frame A) within `range` of B's sensor that have a keypoint of `b`
/// within `distance` once moved by `b_from_a`; nullopt when none is in range. Brute force: a few
/// hundred keypoints each.
std::optional<double> repeatability(const std::vector<Eigen::Vector3f>& a,
                                    const std::vector<Eigen::Vector3f>& b,
                                    const core::Pose3& b_from_a, double range, double distance) {
  int visible = 0, repeated = 0;
  for (const Eigen::Vector3f& k : a) {
    const Eigen::Vector3f in_b = (b_from_a * k.cast<double>()).cast<float>();
    if (in_b.norm() > range) continue;
    ++visible;
    repeated += std::any_of(b.begin(), b.end(), [&](const Eigen::Vector3f& q) {
      return (q - in_b).norm() <= distance;
    });
  }
  if (visible == 0) return std::nullopt;
  return double(repeated) / visible;
}

Results run(const Options& o) {
  std::shared_ptr<const core::place_recognition::PlaceModel> model;
  if (!o.model_dir.empty()) model = core::place_recognition::PlaceModel::load(o.model_dir);
  Results results;
  results.features = model ? model->features : o.features;
  const core::features::FeatureExtractor extractor(results.features);
  auto words = [&](const core::features::LocalFeatures& f) -> std::optional<std::size_t> {
    if (!model) return std::nullopt;
    return model->vocabulary.quantize(f.descriptors).size();
  };
  BagKeyframeOptions options;
  options.truth_topic = "/ground_truth";
  options.keyframe_distance_m = o.keyframe_distance_m;
  for (const std::string& dir : o.missions) {
    struct Keyframe {
      int robot;
      double stamp_s;
      core::Pose3 world_pose;
      std::vector<Eigen::Vector3f> keypoints;
      std::vector<Eigen::Vector3f> random_points;
    };
    std::vector<Keyframe> keyframes;
    Source source{dir, {}, 0, 0.0, 0.0};
    std::mt19937 rng(1);
    const auto bags = missionBags(dir);
    for (std::size_t r = 0; r < bags.size(); ++r) {
      forEachBagKeyframe(bags[r].path, options, extractor, [&](BagKeyframe&& k) {
        source.counts.add(k.stats, words(k.features));
        std::vector<Eigen::Vector3f> in_range;
        for (const auto& p : *k.cloud) {
          if (p.getVector3fMap().norm() <= results.features.max_range_m) {
            in_range.push_back(p.getVector3fMap());
          }
        }
        std::shuffle(in_range.begin(), in_range.end(), rng);
        in_range.resize(std::min(in_range.size(), k.features.keypoints.size()));
        keyframes.push_back({int(r), core::toSeconds(k.stamp),
                             bags[r].world_from_odom * *k.true_pose,
                             std::move(k.features.keypoints), std::move(in_range)});
      });
    }
    double sum = 0.0, chance = 0.0;
    int terms = 0, chance_terms = 0;
    for (std::size_t i = 0; i < keyframes.size(); ++i) {
      for (std::size_t j = i + 1; j < keyframes.size(); ++j) {
        const Keyframe& a = keyframes[i];
        const Keyframe& b = keyframes[j];
        if ((a.world_pose.translation() - b.world_pose.translation()).norm() >
                o.revisit_distance_m ||
            (a.robot == b.robot && std::abs(a.stamp_s - b.stamp_s) < o.revisit_gap_s)) {
          continue;
        }
        ++source.revisits;
        const core::Pose3 b_from_a = b.world_pose.inverse() * a.world_pose;
        for (const auto& share :
             {repeatability(a.keypoints, b.keypoints, b_from_a, results.features.max_range_m,
                            o.repeat_distance_m),
              repeatability(b.keypoints, a.keypoints, b_from_a.inverse(),
                            results.features.max_range_m, o.repeat_distance_m)}) {
          if (share) sum += *share, ++terms;
        }
        for (const auto& share :
             {repeatability(a.random_points, b.random_points, b_from_a,
                            results.features.max_range_m, o.repeat_distance_m),
              repeatability(b.random_points, a.random_points, b_from_a.inverse(),
                            results.features.max_range_m, o.repeat_distance_m)}) {
          if (share) chance += *share, ++chance_terms;
        }
      }
    }
    source.repeatability = terms ? sum / terms : 0.0;
    source.chance = chance_terms ? chance / chance_terms : 0.0;
    results.sources.push_back(std::move(source));
  }
  const core::preprocess::ScanPreprocessor preprocessor{core::preprocess::PreprocessorParams{}};
  for (const std::string& file : o.pcds) {
    pcl::PointCloud<pcl::PointXYZI> scan;
    if (pcl::io::loadPCDFile(file, scan) != 0) throw std::runtime_error("cannot read " + file);
    const auto cloud = preprocessor.process(scan, Eigen::Vector3f::UnitZ());
    core::features::ExtractionStats stats;
    const auto features = extractor.extract(*cloud, Eigen::Vector3f::UnitZ(), &stats);
    Source source{file, {}, 0, 0.0, 0.0};
    source.counts.add(stats, words(features));
    results.sources.push_back(std::move(source));
  }
  return results;
}

void printStatistic(const char* name, std::vector<double> values) {
  if (values.empty()) {
    std::printf("\"%s\": null", name);
    return;
  }
  std::sort(values.begin(), values.end());
  double mean = 0.0;
  for (double v : values) mean += v / values.size();
  std::printf("\"%s\": {\"mean\": %.1f, \"median\": %.1f, \"min\": %.0f, \"max\": %.0f}", name,
              mean, values[values.size() / 2], values.front(), values.back());
}

void report(const Options&, const Results& r) {
  const auto& f = r.features;
  std::printf(
      "{\n  \"benchmark\": \"feature_study\",\n  \"features\": {\"drop_horizontal\": \"%s\", "
      "\"voxel_m\": %g, \"normal_radius_m\": %g, \"iss_salient_radius_m\": %g, "
      "\"iss_non_max_radius_m\": %g, \"spin_support_m\": %g},\n  \"sources\": [\n",
      core::preprocess::toString(f.drop_horizontal), f.voxel_m, f.normal_radius_m,
      f.iss_salient_radius_m, f.iss_non_max_radius_m, f.spin_support_m);
  for (std::size_t i = 0; i < r.sources.size(); ++i) {
    const Source& s = r.sources[i];
    std::printf("    {\"source\": \"%s\", \"keyframes\": %zu, ", s.name.c_str(),
                s.counts.keypoints.size());
    printStatistic("points", s.counts.points);
    std::printf(", ");
    printStatistic("keypoints", s.counts.keypoints);
    std::printf(", ");
    printStatistic("descriptors", s.counts.descriptors);
    std::printf(", ");
    printStatistic("words", s.counts.words);
    std::printf(
        ", \"revisits\": %d, \"repeatability\": %.3f, \"repeatability_by_chance\": %.3f}%s\n",
        s.revisits, s.repeatability, s.chance, i + 1 < r.sources.size() ? "," : "");
  }
  std::printf("  ]\n}\n");
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("eval_features", argc, argv, parse, run, report);
}
