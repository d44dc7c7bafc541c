// Parameters of scan preprocessing and keyframe selection.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::preprocess {

struct PreprocessorParams {
  /// Points closer than this to the sensor are dropped (robot body, operator).
  double min_range_m = 0.5;
  /// Points farther than this are dropped (VLP-16 nominal range is 100 m).
  double max_range_m = 100.0;
  /// Edge of the down-sampling voxel grid.
  double voxel_leaf_m = 0.1;
  /// A new keyframe is made after this much odometry travel since the previous one ...
  double keyframe_distance_m = 1.0;
  /// ... or after this much rotation, whichever comes first.
  double keyframe_rotation_deg = 15.0;
  /// Largest gap between a scan stamp and the odometry used to place it.
  double odom_tolerance_s = 0.1;

  /// Empty when valid; otherwise one message per invalid parameter.
  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::preprocess
