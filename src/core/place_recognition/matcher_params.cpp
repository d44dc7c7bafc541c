#include "ccir_mapping/core/place_recognition/matcher_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::place_recognition {

std::optional<MatchMethod> parseMatchMethod(std::string_view text) {
  if (text == "fabmap") return MatchMethod::kFabmap;
  if (text == "histogram") return MatchMethod::kHistogram;
  return std::nullopt;
}

const char* toString(MatchMethod method) {
  return method == MatchMethod::kFabmap ? "fabmap" : "histogram";
}

std::vector<std::string> MatcherParams::validate() const {
  ParamCheck check;
  check.inRange("min_correspondences", min_correspondences, 0, 10000);
  check.inRange("loop_exclusion_s", loop_exclusion_s, 0.0, 3600.0);
  check.inRange("max_candidates", max_candidates, 1, 1000);
  check.inRange("own_loop_gate_m_per_m", own_loop_gate_m_per_m, 0.0, 10.0);
  check.inRange("own_loop_gate_rad_per_m", own_loop_gate_rad_per_m, 0.0, 10.0);
  check.inRange("min_inliers", min_inliers, 3, 100000);
  check.inHalfOpenRange("max_fitness_m2", max_fitness_m2, 0.0, 100.0);
  check.inRange("min_overlap", min_overlap, 0.0, 1.0);
  check.inHalfOpenRange("overlap_distance_m", overlap_distance_m, 0.0, 10.0);
  check.inRange("max_free_space_violation", max_free_space_violation, 0.0, 1.0);
  check.inHalfOpenRange("free_space_margin_m", free_space_margin_m, 0.0, 10.0);
  return check.errors();
}

}  // namespace ccir_mapping::core::place_recognition
