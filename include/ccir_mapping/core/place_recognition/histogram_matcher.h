// The thesis's baseline place recognition (section 2.2): every descriptor of a query votes for
// the keyframes holding its nearest mapped descriptors (FLANN kd-tree); keyframes with enough
// votes are candidates.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/features/local_features.h"

namespace flann {
template <typename Distance>
class Index;
template <class T>
struct L2;
}  // namespace flann

namespace ccir_mapping::core::place_recognition {

struct HistogramParams {
  /// Nearest mapped descriptors each query descriptor votes for.
  int neighbours = 1;
  /// Farther neighbours do not vote.
  double max_distance = std::numeric_limits<double>::infinity();
  /// Fewer votes never make a candidate.
  int min_votes = 5;
};

struct HistogramCandidate {
  KeyframeId keyframe = 0;
  int votes = 0;
};

class HistogramMatcher {
 public:
  explicit HistogramMatcher(const HistogramParams& params);
  ~HistogramMatcher();

  void addKeyframe(KeyframeId id, const std::vector<features::SpinImage>& descriptors);
  std::size_t keyframes() const { return keyframe_count_; }
  /// Keyframes with at least min_votes votes, most votes first (ties: older keyframe first).
  std::vector<HistogramCandidate> candidates(const std::vector<features::SpinImage>& query) const;

 private:
  void rebuild() const;

  HistogramParams params_;
  std::size_t keyframe_count_ = 0;
  std::vector<float> data_;        // descriptors, row-major
  std::vector<KeyframeId> owner_;  // keyframe of each descriptor
  mutable std::unique_ptr<flann::Index<flann::L2<float>>> index_;
  mutable std::size_t indexed_ = 0;  // descriptors in index_
};

}  // namespace ccir_mapping::core::place_recognition
