// The local 3D features of one keyframe: ISS keypoints with their spin images.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

namespace ccir_mapping::core::features {

/// PCL's spin image of width 8: (8 + 1) x (2 * 8 + 1) = 153 bins, summing to 1. The only width
/// that is safe with PCL 1.13 (other widths overrun Histogram<N>).
constexpr int kSpinImageWidth = 8;
constexpr int kSpinImageBins = (kSpinImageWidth + 1) * (2 * kSpinImageWidth + 1);
using SpinImage = std::array<float, kSpinImageBins>;

struct LocalFeatures {
  /// In the keyframe cloud's frame; keypoints[i] is described by descriptors[i].
  std::vector<Eigen::Vector3f> keypoints;
  /// Every value finite, each image summing to 1.
  std::vector<SpinImage> descriptors;

  std::size_t size() const { return keypoints.size(); }
};

}  // namespace ccir_mapping::core::features
