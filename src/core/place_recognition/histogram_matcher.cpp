#include "ccir_mapping/core/place_recognition/histogram_matcher.h"

#include <algorithm>
#include <map>
#include <stdexcept>

#include <flann/flann.hpp>

namespace ccir_mapping::core::place_recognition {

using features::kSpinImageBins;

HistogramMatcher::HistogramMatcher(const HistogramParams& params) : params_(params) {
  if (params.neighbours < 1 || params.min_votes < 1 || !(params.max_distance > 0.0)) {
    throw std::invalid_argument(
        "histogram matcher: neighbours and min_votes >= 1, max_distance > 0");
  }
}

HistogramMatcher::~HistogramMatcher() = default;

void HistogramMatcher::addKeyframe(KeyframeId id,
                                   const std::vector<features::SpinImage>& descriptors) {
  for (const auto& d : descriptors) {
    data_.insert(data_.end(), d.begin(), d.end());
    owner_.push_back(id);
  }
  ++keyframe_count_;
}

void HistogramMatcher::rebuild() const {
  // The kd-tree is rebuilt when descriptors were added since the last query; FLANN holds a view
  // of data_, which does not change between rebuilds.
  if (indexed_ == owner_.size()) return;
  flann::Matrix<float> matrix(const_cast<float*>(data_.data()), owner_.size(), kSpinImageBins);
  index_ =
      std::make_unique<flann::Index<flann::L2<float>>>(matrix, flann::KDTreeSingleIndexParams());
  index_->buildIndex();
  indexed_ = owner_.size();
}

std::vector<HistogramCandidate> HistogramMatcher::candidates(
    const std::vector<features::SpinImage>& query) const {
  std::vector<HistogramCandidate> result;
  if (query.empty() || owner_.empty()) return result;
  rebuild();
  const int k = std::min<int>(params_.neighbours, static_cast<int>(owner_.size()));
  flann::Matrix<float> queries(const_cast<float*>(query.front().data()), query.size(),
                               kSpinImageBins);
  std::vector<std::vector<size_t>> indices;
  std::vector<std::vector<float>> squared;
  index_->knnSearch(queries, indices, squared, k,
                    flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  const double max2 = params_.max_distance * params_.max_distance;
  std::map<KeyframeId, int> votes;
  for (std::size_t q = 0; q < query.size(); ++q) {
    std::vector<KeyframeId> voted;  // one vote per keyframe and query descriptor
    for (std::size_t n = 0; n < indices[q].size(); ++n) {
      if (squared[q][n] > max2) continue;
      const KeyframeId keyframe = owner_[indices[q][n]];
      if (std::find(voted.begin(), voted.end(), keyframe) != voted.end()) continue;
      voted.push_back(keyframe);
      ++votes[keyframe];
    }
  }
  for (const auto& [keyframe, count] : votes) {
    if (count >= params_.min_votes) result.push_back({keyframe, count});
  }
  std::stable_sort(result.begin(), result.end(),
                   [](const auto& a, const auto& b) { return a.votes > b.votes; });
  return result;
}

}  // namespace ccir_mapping::core::place_recognition
