#include "ccir_mapping/core/features/descriptor_matcher.h"

#include <flann/flann.hpp>

namespace ccir_mapping::core::features {
namespace {

/// For each row of `queries`, its nearest row of `data` if it passes the ratio test, else -1.
std::vector<int> nearestPassingRatio(const std::vector<SpinImage>& data,
                                     const std::vector<SpinImage>& queries, double ratio) {
  std::vector<int> nearest(queries.size(), -1);
  if (data.size() < 2 || queries.empty()) return nearest;
  // FLANN reads the descriptors in place (std::array rows are contiguous).
  flann::Matrix<float> data_matrix(const_cast<float*>(data.front().data()), data.size(),
                                   kSpinImageBins);
  flann::Matrix<float> query_matrix(const_cast<float*>(queries.front().data()), queries.size(),
                                    kSpinImageBins);
  flann::Index<flann::L2<float>> index(data_matrix, flann::KDTreeSingleIndexParams());
  index.buildIndex();
  std::vector<std::vector<size_t>> indices;
  std::vector<std::vector<float>> squared;
  index.knnSearch(query_matrix, indices, squared, 2,
                  flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  const float ratio2 = static_cast<float>(ratio * ratio);
  for (std::size_t q = 0; q < queries.size(); ++q) {
    if (squared[q].size() == 2 && squared[q][0] < ratio2 * squared[q][1]) {
      nearest[q] = static_cast<int>(indices[q][0]);
    }
  }
  return nearest;
}

}  // namespace

std::vector<std::pair<int, int>> mutualMatches(const std::vector<SpinImage>& a,
                                               const std::vector<SpinImage>& b, double ratio) {
  const std::vector<int> a_to_b = nearestPassingRatio(b, a, ratio);
  const std::vector<int> b_to_a = nearestPassingRatio(a, b, ratio);
  std::vector<std::pair<int, int>> matches;
  for (std::size_t i = 0; i < a_to_b.size(); ++i) {
    const int j = a_to_b[i];
    if (j >= 0 && b_to_a[static_cast<std::size_t>(j)] == static_cast<int>(i)) {
      matches.emplace_back(static_cast<int>(i), j);
    }
  }
  return matches;
}

}  // namespace ccir_mapping::core::features
