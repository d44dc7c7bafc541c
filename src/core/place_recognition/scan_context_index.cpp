#include "ccir_mapping/core/place_recognition/scan_context_index.h"

#include <algorithm>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::place_recognition {

ScanContextIndex::ScanContextIndex(const ScanContextParams& params) : params_(validated(params)) {}

void ScanContextIndex::add(ScanContext context) { places_.push_back(std::move(context)); }

std::vector<ScanContextIndex::Match> ScanContextIndex::query(
    const ScanContext& query, const std::function<bool(std::size_t)>& eligible) const {
  // Ring keys have ~20 entries: comparing them all is ~20 k operations at 1000 places, cheaper
  // than keeping a kd-tree (the paper's) up to date as places are added one by one.
  std::vector<std::pair<float, std::size_t>> nearest;
  for (std::size_t i = 0; i < places_.size(); ++i) {
    if (!eligible(i)) continue;
    nearest.emplace_back((places_[i].ringKey() - query.ringKey()).squaredNorm(), i);
  }
  const auto k = std::min(nearest.size(), static_cast<std::size_t>(params_.ring_key_candidates));
  std::partial_sort(nearest.begin(), nearest.begin() + static_cast<std::ptrdiff_t>(k),
                    nearest.end());
  std::vector<Match> matches;
  for (std::size_t n = 0; n < k; ++n) {
    const std::size_t i = nearest[n].second;
    matches.push_back({i, scanContextDistance(query, places_[i], params_)});
  }
  std::stable_sort(matches.begin(), matches.end(), [](const Match& a, const Match& b) {
    return a.distance.distance < b.distance.distance;
  });
  return matches;
}

}  // namespace ccir_mapping::core::place_recognition
