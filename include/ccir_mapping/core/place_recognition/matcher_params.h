// Parameters of place recognition and loop-closure detection.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ccir_mapping::core::place_recognition {

/// FAB-MAP over bags of spin-image words, or the histogram-of-descriptors baseline.
enum class MatchMethod { kFabmap, kHistogram };
constexpr std::string_view kMatchMethodChoices = "fabmap | histogram";
std::optional<MatchMethod> parseMatchMethod(std::string_view text);
const char* toString(MatchMethod method);

struct MatcherParams {
  MatchMethod method = MatchMethod::kFabmap;
  /// Vocabulary and Chow-Liu model directory; empty = the model shipped with the package.
  std::string model_dir;
  /// A keyframe is a loop-closure candidate only with more correspondences than this (c_k,min).
  int min_correspondences = 5;
  /// Own keyframes younger than this are never matched against (temporal exclusion window).
  double loop_exclusion_s = 30.0;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::place_recognition
