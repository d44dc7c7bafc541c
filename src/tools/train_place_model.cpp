// train_place_model: learns the place-recognition model - spin-image vocabulary, Chow-Liu tree
// and new-place samples - from rosbags of missions that do not overlap the places to recognise
// later. Keyframes are taken every --keyframe-distance-m of odometry, preprocessed and described
// as the pipeline does. The vocabulary and the tree learn from --bags; FAB-MAP's new-place
// samples come from other keyframes (--sample-bags, or every second keyframe of --bags), since
// the tree's own training keyframes make every place it learnt look familiar. Writes
// DIR/vocabulary.bin, DIR/chow_liu_tree.txt, DIR/samples.txt and DIR/model.yaml.
// Exit codes: 0 done, 1 cannot read or write, 2 bad arguments.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include <boost/program_options.hpp>

#include "bag_keyframes.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "command_line.h"
#include "feature_options.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace tools = ccir_mapping::tools;

namespace {

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> sample_bags;
  std::string out;
  int words = 500;
  double keyframe_distance_m = 2.0;
  int max_descriptors = 100000;
  int seed = 1;
  std::string points_topic = "/velodyne_points";
  std::string odom_topic = "/odom";
  core::features::FeatureParams features;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: train_place_model --bags A.bag [B.bag ...] [--sample-bags C.bag ...] --out DIR\n"
      "Learns the vocabulary, the Chow-Liu tree and the new-place samples from missions that do\n"
      "not overlap the places to recognise.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "bags", po::value<std::vector<std::string>>(&o->bags)->multitoken(),
      "rosbags the vocabulary and the Chow-Liu tree learn from")(
      "sample-bags", po::value<std::vector<std::string>>(&o->sample_bags)->multitoken(),
      "rosbags of the new-place samples (default: every second keyframe of --bags, which the "
      "tree then does not learn from)")("out", po::value<std::string>(&o->out),
                                        "output directory (created)")(
      "words", po::value<int>(&o->words)->default_value(o->words), "vocabulary size")(
      "keyframe-distance-m",
      po::value<double>(&o->keyframe_distance_m)->default_value(o->keyframe_distance_m),
      "odometry travel between training keyframes [m]")(
      "max-descriptors", po::value<int>(&o->max_descriptors)->default_value(o->max_descriptors),
      "descriptors the vocabulary is clustered from (a seeded sample beyond that)")(
      "seed", po::value<int>(&o->seed)->default_value(o->seed), "clustering and sampling seed")(
      "points-topic", po::value<std::string>(&o->points_topic)->default_value(o->points_topic),
      "clouds")("odom-topic", po::value<std::string>(&o->odom_topic)->default_value(o->odom_topic),
                "odometry");
  const tools::FeatureOptions features(&options, &o->features);
  if (const auto exit_code = tools::parseCommandLine("train_place_model", options, argc, argv)) {
    return exit_code;
  }
  if (const std::string error = features.apply(); !error.empty()) {
    return tools::usageError("train_place_model", error);
  }
  if (o->bags.empty() || o->out.empty() || o->words < 2 || !(o->keyframe_distance_m > 0) ||
      o->max_descriptors < o->words) {
    return tools::usageError("train_place_model",
                             "need --bags and --out, --words >= 2, --keyframe-distance-m > 0, "
                             "--max-descriptors >= --words");
  }
  return std::nullopt;
}

/// The model learnt from the bags' keyframes, and what it was learnt from.
struct Results {
  std::size_t keyframes = 0;
  std::size_t samples = 0;
  std::size_t descriptors = 0;
  double words_per_keyframe = 0.0;
  std::shared_ptr<const core::place_recognition::PlaceModel> model;
};

/// Throws std::runtime_error (a bag that cannot be read, too few descriptors, a model that
/// cannot be written).
Results run(const Options& o) {
  const core::features::FeatureExtractor extractor(o.features);
  BagKeyframeOptions keyframe_options;
  keyframe_options.points_topic = o.points_topic;
  keyframe_options.odom_topic = o.odom_topic;
  keyframe_options.keyframe_distance_m = o.keyframe_distance_m;
  auto read = [&](const std::vector<std::string>& bags) {
    std::vector<core::features::LocalFeatures> keyframes;
    for (const std::string& path : bags) {
      const std::size_t count =
          forEachBagKeyframe(path, keyframe_options, extractor,
                             [&](BagKeyframe&& k) { keyframes.push_back(std::move(k.features)); });
      std::printf("train_place_model: %s: %zu keyframes\n", path.c_str(), count);
    }
    return keyframes;
  };
  std::vector<core::features::LocalFeatures> keyframes = read(o.bags);
  std::vector<core::features::LocalFeatures> sample_keyframes = read(o.sample_bags);
  if (o.sample_bags.empty()) {  // hold every second keyframe out of the tree
    std::vector<core::features::LocalFeatures> kept;
    for (std::size_t i = 0; i < keyframes.size(); ++i) {
      (i % 2 ? sample_keyframes : kept).push_back(std::move(keyframes[i]));
    }
    keyframes = std::move(kept);
  }
  if (sample_keyframes.empty()) throw std::runtime_error("no keyframes for new-place samples");
  std::vector<core::features::SpinImage> descriptors;
  for (const auto& k : keyframes)
    descriptors.insert(descriptors.end(), k.descriptors.begin(), k.descriptors.end());
  if (descriptors.size() < static_cast<std::size_t>(o.words)) {
    throw std::runtime_error("only " + std::to_string(descriptors.size()) + " descriptors from " +
                             std::to_string(keyframes.size()) + " keyframes for " +
                             std::to_string(o.words) + " words");
  }
  std::mt19937 rng(static_cast<unsigned>(o.seed));
  if (descriptors.size() > static_cast<std::size_t>(o.max_descriptors)) {
    std::shuffle(descriptors.begin(), descriptors.end(), rng);
    descriptors.resize(static_cast<std::size_t>(o.max_descriptors));
  }
  auto vocabulary = core::place_recognition::Vocabulary::train(descriptors, o.words, o.seed);
  std::vector<core::place_recognition::WordSet> sets, samples;
  for (const auto& k : keyframes) sets.push_back(vocabulary.quantize(k.descriptors));
  for (const auto& k : sample_keyframes) samples.push_back(vocabulary.quantize(k.descriptors));
  auto tree = core::place_recognition::ChowLiuTree::learn(sets, vocabulary.size());
  std::ostringstream about;
  about << "training_keyframes: " << keyframes.size()
        << "\nsample_keyframes: " << sample_keyframes.size()
        << "\ndescriptors: " << descriptors.size()
        << "\nkeyframe_distance_m: " << o.keyframe_distance_m << "\nbags:\n";
  for (const auto& bag : o.bags) {
    about << "  - " << std::filesystem::path(bag).filename().string() << '\n';
  }
  about << "sample_bags:" << (o.sample_bags.empty() ? "  # every second keyframe of bags\n" : "\n");
  for (const auto& bag : o.sample_bags) {
    about << "  - " << std::filesystem::path(bag).filename().string() << '\n';
  }
  Results r;
  r.keyframes = keyframes.size();
  r.samples = samples.size();
  r.descriptors = descriptors.size();
  for (const auto& set : sets) r.words_per_keyframe += set.size();
  r.words_per_keyframe /= double(std::max<std::size_t>(1, sets.size()));
  auto model =
      std::make_shared<core::place_recognition::PlaceModel>(core::place_recognition::PlaceModel{
          std::move(vocabulary), std::move(tree), std::move(samples), o.features});
  model->save(o.out, about.str());
  r.model = std::move(model);
  return r;
}

void report(const Options& o, const Results& r) {
  std::printf(
      "train_place_model: %zu words (hash %s) from %zu descriptors; tree from %zu keyframes, "
      "%.0f words each on average; %zu new-place samples -> %s\n",
      r.model->vocabulary.size(), r.model->vocabulary.hash().c_str(), r.descriptors, r.keyframes,
      r.words_per_keyframe, r.samples, o.out.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("train_place_model", argc, argv, parse, run, report);
}
