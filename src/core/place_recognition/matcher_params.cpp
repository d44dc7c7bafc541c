#include "ccir_mapping/core/place_recognition/matcher_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::place_recognition {

std::optional<MatchMethod> parseMatchMethod(std::string_view text) {
  if (text == "fabmap") return MatchMethod::kFabmap;
  if (text == "histogram") return MatchMethod::kHistogram;
  if (text == "scan_context") return MatchMethod::kScanContext;
  if (text == "hgmm") return MatchMethod::kHgmm;
  return std::nullopt;
}

const char* toString(MatchMethod method) {
  switch (method) {
    case MatchMethod::kFabmap:
      return "fabmap";
    case MatchMethod::kHistogram:
      return "histogram";
    case MatchMethod::kScanContext:
      return "scan_context";
    case MatchMethod::kHgmm:
      return "hgmm";
  }
  return "?";
}

std::optional<MixtureCandidates> parseMixtureCandidates(std::string_view text) {
  if (text == "scan_context") return MixtureCandidates::kScanContext;
  if (text == "all") return MixtureCandidates::kAll;
  return std::nullopt;
}

const char* toString(MixtureCandidates candidates) {
  return candidates == MixtureCandidates::kAll ? "all" : "scan_context";
}

std::vector<std::string> MixtureMatchParams::validate() const {
  auto errors = model.validate();
  for (auto& error : registration.validate()) errors.push_back(std::move(error));
  return errors;
}

std::vector<std::string> SearchParams::validate() const {
  ParamCheck check;
  check.inRange("search_reach_m", reach_m, 0.0, 1000.0);
  check.inRange("search_max_drift_m", max_drift_m, 0.0, 10000.0);
  check.inRange("gated_candidates", gated_candidates, 1, 1000);
  check.inRange("prior_free_verifications_per_s", prior_free_verifications_per_s, 0.0, 1000.0);
  check.inRange("prior_free_horizon_s", prior_free_horizon_s, 0.001, 3600.0);
  return check.errors();
}

std::vector<std::string> MatcherParams::validate() const {
  ParamCheck check;
  check.inRange("min_correspondences", min_correspondences, 0, 10000);
  check.inRange("loop_exclusion_s", loop_exclusion_s, 0.0, 3600.0);
  check.inRange("max_candidates", max_candidates, 1, 1000);
  check.inRange("min_place_probability", min_place_probability, 0.0, 1.0);
  check.inRange("complete_places", complete_places, 1, 1000000);
  check.inRange("own_loop_gate_m_per_m", own_loop_gate_m_per_m, 0.0, 10.0);
  check.inRange("own_loop_gate_rad_per_m", own_loop_gate_rad_per_m, 0.0, 10.0);
  auto errors = check.errors();
  for (auto& error : verification.validate()) errors.push_back(std::move(error));
  for (auto& error : search.validate()) errors.push_back(std::move(error));
  for (auto& error : fabmap.validate()) errors.push_back(std::move(error));
  for (auto& error : scan_context.validate()) errors.push_back(std::move(error));
  for (auto& error : hgmm.validate()) errors.push_back(std::move(error));
  return errors;
}

}  // namespace ccir_mapping::core::place_recognition
