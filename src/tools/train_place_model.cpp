// train_place_model: learns the place-recognition model - spin-image vocabulary, Chow-Liu tree
// and new-place samples - from rosbags of missions that do not overlap the places to recognise
// later. Keyframes are taken every --keyframe-distance-m of odometry, preprocessed and described
// as the pipeline does. Writes DIR/vocabulary.bin, DIR/chow_liu_tree.txt, DIR/samples.txt and
// DIR/model.yaml. Exit codes: 0 done, 1 cannot read or write, 2 bad arguments.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

#include <boost/program_options.hpp>

#include "bag_keyframes.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/place_recognition/place_model.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;

int main(int argc, char** argv) {
  std::vector<std::string> bags;
  std::string out;
  int words = 500;
  double keyframe_distance_m = 2.0;
  int max_descriptors = 100000;
  int seed = 1;
  std::string points_topic = "/velodyne_points";
  std::string odom_topic = "/odom";
  core::features::FeatureParams feature_params;
  std::string drop_horizontal = core::preprocess::toString(feature_params.drop_horizontal);
  po::options_description options(
      "Usage: train_place_model --bags A.bag [B.bag ...] --out DIR [--words 500]\n"
      "Learns the vocabulary, the Chow-Liu tree and the new-place samples from missions that do\n"
      "not overlap the places to recognise.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "bags", po::value<std::vector<std::string>>(&bags)->multitoken(), "training rosbags")(
      "out", po::value<std::string>(&out), "output directory (created)")(
      "words", po::value<int>(&words)->default_value(words), "vocabulary size")(
      "keyframe-distance-m",
      po::value<double>(&keyframe_distance_m)->default_value(keyframe_distance_m),
      "odometry travel between training keyframes [m]")(
      "max-descriptors", po::value<int>(&max_descriptors)->default_value(max_descriptors),
      "descriptors the vocabulary is clustered from (a seeded sample beyond that)")(
      "seed", po::value<int>(&seed)->default_value(seed), "clustering and sampling seed")(
      "points-topic", po::value<std::string>(&points_topic)->default_value(points_topic), "clouds")(
      "odom-topic", po::value<std::string>(&odom_topic)->default_value(odom_topic), "odometry")(
      "feature-drop-horizontal",
      po::value<std::string>(&drop_horizontal)->default_value(drop_horizontal),
      "degenerate-normal filter of the features: none | ground | ceiling | both")(
      "iss-non-max-radius-m",
      po::value<double>(&feature_params.iss_non_max_radius_m)
          ->default_value(feature_params.iss_non_max_radius_m),
      "ISS non-maximum suppression radius [m]");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "train_place_model: " << e.what() << " (see --help)\n";
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  const auto filter = core::preprocess::parseHorizontalFilter(drop_horizontal);
  if (filter) feature_params.drop_horizontal = *filter;
  if (!filter || !feature_params.validate().empty() || bags.empty() || out.empty() || words < 2 ||
      !(keyframe_distance_m > 0) || max_descriptors < words) {
    std::cerr
        << "train_place_model: need --bags and --out, --words >= 2, --keyframe-distance-m > 0, "
           "--max-descriptors >= --words\n";
    return 2;
  }

  const core::features::FeatureExtractor extractor(feature_params);
  BagKeyframeOptions keyframe_options;
  keyframe_options.points_topic = points_topic;
  keyframe_options.odom_topic = odom_topic;
  keyframe_options.keyframe_distance_m = keyframe_distance_m;
  std::vector<core::features::LocalFeatures> keyframes;
  try {
    for (const std::string& path : bags) {
      const std::size_t count =
          forEachBagKeyframe(path, keyframe_options, extractor,
                             [&](BagKeyframe&& k) { keyframes.push_back(std::move(k.features)); });
      std::printf("train_place_model: %s: %zu keyframes\n", path.c_str(), count);
    }
  } catch (const std::exception& e) {
    std::cerr << "train_place_model: " << e.what() << '\n';
    return 1;
  }

  std::vector<core::features::SpinImage> descriptors;
  for (const auto& k : keyframes)
    descriptors.insert(descriptors.end(), k.descriptors.begin(), k.descriptors.end());
  if (descriptors.size() < static_cast<std::size_t>(words)) {
    std::cerr << "train_place_model: only " << descriptors.size() << " descriptors from "
              << keyframes.size() << " keyframes for " << words << " words\n";
    return 1;
  }
  std::mt19937 rng(static_cast<unsigned>(seed));
  if (descriptors.size() > static_cast<std::size_t>(max_descriptors)) {
    std::shuffle(descriptors.begin(), descriptors.end(), rng);
    descriptors.resize(static_cast<std::size_t>(max_descriptors));
  }
  try {
    auto vocabulary = core::place_recognition::Vocabulary::train(descriptors, words, seed);
    std::vector<core::place_recognition::WordSet> sets;
    for (const auto& k : keyframes) sets.push_back(vocabulary.quantize(k.descriptors));
    auto tree = core::place_recognition::ChowLiuTree::learn(sets, vocabulary.size());
    std::ostringstream about;
    about << "training_keyframes: " << keyframes.size() << "\ndescriptors: " << descriptors.size()
          << "\nkeyframe_distance_m: " << keyframe_distance_m << "\nbags:\n";
    for (const auto& bag : bags) {
      about << "  - " << std::filesystem::path(bag).filename().string() << '\n';
    }
    const core::place_recognition::PlaceModel model{std::move(vocabulary), std::move(tree), sets,
                                                    feature_params};
    model.save(out, about.str());
    double words_per_keyframe = 0;
    for (const auto& set : sets) words_per_keyframe += set.size();
    std::printf(
        "train_place_model: %zu words (hash %s) from %zu descriptors; %zu keyframes, "
        "%.0f words each on average -> %s\n",
        model.vocabulary.size(), model.vocabulary.hash().c_str(), descriptors.size(),
        keyframes.size(), words_per_keyframe / std::max<std::size_t>(1, sets.size()), out.c_str());
  } catch (const std::exception& e) {
    std::cerr << "train_place_model: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
