// Parameters of ISS keypoints and spin images on sparse 16-beam keyframes
// (algorithms.md section 2.5; defaults measured on the real VLP-16 scans).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccir_mapping/core/preprocess/horizontal_filter.h"

namespace ccir_mapping::core::features {

/// The axis spin images turn around: gravity up (repeatable on ground robots) or each
/// keypoint's normal (the original formulation).
enum class SpinAxis { kZUp, kNormal };
constexpr std::string_view kSpinAxisChoices = "z_up | normal";
std::optional<SpinAxis> parseSpinAxis(std::string_view text);
const char* toString(SpinAxis axis);

struct FeatureParams {
  /// Only points within this range of the sensor take part: far points are too sparse to
  /// describe a place.
  double max_range_m = 40.0;
  /// The thesis's degenerate-normal filter before keypoints (horizontal_filter.h).
  preprocess::HorizontalFilter drop_horizontal = preprocess::HorizontalFilter::kBoth;
  double horizontal_normal_z = 0.5;
  /// Voxel edge of the cloud keypoints and descriptors are computed on (coarser than the
  /// keyframe's); 0 uses the keyframe cloud as it is.
  double voxel_m = 0.2;
  /// Normals are estimated again at this scale (viewpoint at the sensor).
  double normal_radius_m = 0.8;
  double iss_salient_radius_m = 1.0;
  /// Non-maximum suppression radius: sets the keypoint count. 0.5 m: ~175 per simulated mine
  /// keyframe and 90-190 on the real VLP-16 scans with the "both" filter (1.5 m: 27 and 40-50,
  /// too few for FAB-MAP and RANSAC; docs/results.md, feature study).
  double iss_non_max_radius_m = 0.5;
  double iss_gamma_21 = 0.975;
  double iss_gamma_32 = 0.975;
  int iss_min_neighbors = 5;
  /// Spin image support radius R (the image is 8 x 8 bins over a cylinder of R / sqrt(2)).
  double spin_support_m = 2.5;
  SpinAxis spin_axis = SpinAxis::kZUp;
  /// Keypoints with fewer points within spin_support_m get no descriptor.
  int spin_min_neighbors = 10;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::features
