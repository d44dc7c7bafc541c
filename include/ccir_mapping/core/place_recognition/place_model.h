// A trained place-recognition model, as train_place_model writes it into a directory:
// vocabulary.bin, chow_liu_tree.txt, samples.txt (new-place word sets) and model.yaml (what it
// was trained on, including the feature settings the descriptors must be computed with).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ccir_mapping/core/features/feature_params.h"
#include "ccir_mapping/core/place_recognition/chow_liu_tree.h"
#include "ccir_mapping/core/place_recognition/vocabulary.h"

namespace ccir_mapping::core::place_recognition {

struct PlaceModel {
  Vocabulary vocabulary;
  ChowLiuTree tree;
  /// Word sets of training keyframes, for FAB-MAP's sampled new-place likelihood.
  std::vector<WordSet> samples;
  /// The settings the training descriptors were computed with: queries must use the same.
  features::FeatureParams features;

  /// Throws std::runtime_error naming the file that is missing, malformed or made for another
  /// vocabulary.
  static std::shared_ptr<const PlaceModel> load(const std::string& dir);
  /// Writes the four files; `about` is extra YAML (training bags, counts) for model.yaml.
  void save(const std::string& dir, const std::string& about) const;
};

}  // namespace ccir_mapping::core::place_recognition
