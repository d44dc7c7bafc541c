#include "ccir_mapping/core/place_recognition/place_model.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <yaml-cpp/yaml.h>

namespace ccir_mapping::core::place_recognition {
namespace {

namespace fs = std::filesystem;

constexpr char kSamplesHeader[] = "# ccir_mapping new-place samples 1 ";

std::vector<WordSet> readSamples(const fs::path& path, const Vocabulary& vocabulary) {
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(path.string() + ": cannot read");
  if (line != kSamplesHeader + vocabulary.hash()) {
    throw std::runtime_error(path.string() + ": not new-place samples for vocabulary " +
                             vocabulary.hash());
  }
  std::vector<WordSet> samples;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    WordSet set;
    for (std::uint32_t w; words >> w;) {
      if (w >= vocabulary.size() || (!set.empty() && w <= set.back())) {
        throw std::runtime_error(path.string() + ": line " + std::to_string(samples.size() + 2) +
                                 " is not a sorted set of word ids below " +
                                 std::to_string(vocabulary.size()));
      }
      set.push_back(w);
    }
    samples.push_back(std::move(set));
  }
  if (samples.empty()) throw std::runtime_error(path.string() + ": no samples");
  return samples;
}

features::FeatureParams readFeatureParams(const fs::path& path, const Vocabulary& vocabulary) {
  features::FeatureParams params;
  try {
    const YAML::Node model = YAML::LoadFile(path.string());
    if (model["vocabulary_hash"].as<std::string>("") != vocabulary.hash()) {
      throw std::runtime_error("vocabulary_hash is not " + vocabulary.hash());
    }
    const YAML::Node f = model["features"];
    if (!f) throw std::runtime_error("no features section");
    const auto filter = preprocess::parseHorizontalFilter(f["drop_horizontal"].as<std::string>(""));
    if (!filter) throw std::runtime_error("features.drop_horizontal is not a filter name");
    params.drop_horizontal = *filter;
    const auto axis = features::parseSpinAxis(f["spin_axis"].as<std::string>("z_up"));
    if (!axis) throw std::runtime_error("features.spin_axis is not z_up or normal");
    params.spin_axis = *axis;
    // Fields a model does not record keep the defaults they had when it was trained.
    auto read = [&](const char* key, auto* field) {
      *field = f[key].as<std::remove_pointer_t<decltype(field)>>(*field);
    };
    read("max_range_m", &params.max_range_m);
    read("horizontal_normal_z", &params.horizontal_normal_z);
    read("voxel_m", &params.voxel_m);
    read("normal_radius_m", &params.normal_radius_m);
    read("iss_salient_radius_m", &params.iss_salient_radius_m);
    params.iss_non_max_radius_m = f["iss_non_max_radius_m"].as<double>();
    read("iss_gamma_21", &params.iss_gamma_21);
    read("iss_gamma_32", &params.iss_gamma_32);
    read("iss_min_neighbors", &params.iss_min_neighbors);
    read("spin_support_m", &params.spin_support_m);
    read("spin_min_neighbors", &params.spin_min_neighbors);
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
  const auto errors = params.validate();
  if (!errors.empty()) throw std::runtime_error(path.string() + ": " + errors.front());
  return params;
}

}  // namespace

std::shared_ptr<const PlaceModel> PlaceModel::load(const std::string& dir) {
  const fs::path root(dir);
  if (!fs::is_directory(root)) {
    throw std::runtime_error(dir + " is not a directory (a train_place_model output)");
  }
  Vocabulary vocabulary = Vocabulary::load((root / "vocabulary.bin").string());
  ChowLiuTree tree = ChowLiuTree::load((root / "chow_liu_tree.txt").string(), vocabulary.hash(),
                                       vocabulary.size());
  std::vector<WordSet> samples = readSamples(root / "samples.txt", vocabulary);
  const features::FeatureParams params = readFeatureParams(root / "model.yaml", vocabulary);
  return std::make_shared<const PlaceModel>(
      PlaceModel{std::move(vocabulary), std::move(tree), std::move(samples), params});
}

void PlaceModel::save(const std::string& dir, const std::string& about) const {
  const fs::path root(dir);
  fs::create_directories(root);
  vocabulary.save((root / "vocabulary.bin").string());
  tree.save((root / "chow_liu_tree.txt").string(), vocabulary.hash());
  std::ofstream out(root / "samples.txt");
  out << kSamplesHeader << vocabulary.hash() << '\n';
  for (const auto& set : samples) {
    for (std::size_t i = 0; i < set.size(); ++i) out << (i ? " " : "") << set[i];
    out << '\n';
  }
  std::ofstream model(root / "model.yaml");
  model << "# Place-recognition model written by train_place_model\n"
        << "vocabulary_hash: " << vocabulary.hash() << "\nwords: " << vocabulary.size()
        << "\nfeatures:  # the descriptors of every query must be computed the same way\n"
        << "  max_range_m: " << features.max_range_m
        << "\n  drop_horizontal: " << preprocess::toString(features.drop_horizontal)
        << "\n  horizontal_normal_z: " << features.horizontal_normal_z
        << "\n  voxel_m: " << features.voxel_m
        << "\n  normal_radius_m: " << features.normal_radius_m
        << "\n  iss_salient_radius_m: " << features.iss_salient_radius_m
        << "\n  iss_non_max_radius_m: " << features.iss_non_max_radius_m
        << "\n  iss_gamma_21: " << features.iss_gamma_21
        << "\n  iss_gamma_32: " << features.iss_gamma_32
        << "\n  iss_min_neighbors: " << features.iss_min_neighbors
        << "\n  spin_support_m: " << features.spin_support_m
        << "\n  spin_axis: " << features::toString(features.spin_axis)
        << "\n  spin_min_neighbors: " << features.spin_min_neighbors << '\n'
        << about;
  if (!out || !model) throw std::runtime_error("cannot write into " + dir);
}

}  // namespace ccir_mapping::core::place_recognition
