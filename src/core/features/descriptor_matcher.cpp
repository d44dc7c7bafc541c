#include "ccir_mapping/core/features/descriptor_matcher.h"

#include <algorithm>
#include <set>

#include <flann/flann.hpp>

namespace ccir_mapping::core::features {
namespace {

/// The k nearest rows of `data` for each row of `queries` (exact FLANN kd-tree, L2).
std::vector<std::vector<size_t>> nearest(const std::vector<SpinImage>& data,
                                         const std::vector<SpinImage>& queries, int k,
                                         std::vector<std::vector<float>>& squared) {
  std::vector<std::vector<size_t>> indices(queries.size());
  squared.assign(queries.size(), {});
  if (data.empty() || queries.empty()) return indices;
  // FLANN reads the descriptors in place (std::array rows are contiguous).
  flann::Matrix<float> data_matrix(const_cast<float*>(data.front().data()), data.size(),
                                   kSpinImageBins);
  flann::Matrix<float> query_matrix(const_cast<float*>(queries.front().data()), queries.size(),
                                    kSpinImageBins);
  flann::Index<flann::L2<float>> index(data_matrix, flann::KDTreeSingleIndexParams());
  index.buildIndex();
  index.knnSearch(query_matrix, indices, squared,
                  static_cast<size_t>(std::min<std::size_t>(k, data.size())),
                  flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  return indices;
}

/// For each row of `queries`, its nearest row of `data` if it passes the ratio test, else -1.
std::vector<int> nearestPassingRatio(const std::vector<SpinImage>& data,
                                     const std::vector<SpinImage>& queries, double ratio) {
  std::vector<int> result(queries.size(), -1);
  if (data.size() < 2) return result;
  std::vector<std::vector<float>> squared;
  const auto indices = nearest(data, queries, 2, squared);
  const float ratio2 = static_cast<float>(ratio * ratio);
  for (std::size_t q = 0; q < queries.size(); ++q) {
    if (squared[q].size() == 2 && squared[q][0] < ratio2 * squared[q][1]) {
      result[q] = static_cast<int>(indices[q][0]);
    }
  }
  return result;
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

std::vector<std::pair<int, int>> nearestMatches(const std::vector<SpinImage>& a,
                                                const std::vector<SpinImage>& b, int k) {
  std::set<std::pair<int, int>> pairs;
  std::vector<std::vector<float>> unused;
  const auto a_to_b = nearest(b, a, k, unused);
  for (std::size_t i = 0; i < a_to_b.size(); ++i) {
    for (size_t j : a_to_b[i]) pairs.emplace(static_cast<int>(i), static_cast<int>(j));
  }
  const auto b_to_a = nearest(a, b, k, unused);
  for (std::size_t j = 0; j < b_to_a.size(); ++j) {
    for (size_t i : b_to_a[j]) pairs.emplace(static_cast<int>(i), static_cast<int>(j));
  }
  return {pairs.begin(), pairs.end()};
}

}  // namespace ccir_mapping::core::features
