// Parameters of scan preprocessing and keyframe selection.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/preprocess/horizontal_filter.h"

namespace ccir_mapping::core::preprocess {

struct PreprocessorParams {
  /// Points closer than this to the sensor are dropped (robot body, operator).
  double min_range_m = 0.5;
  /// Points farther than this are dropped (VLP-16 nominal range is 100 m).
  double max_range_m = 100.0;
  /// Edge of the down-sampling voxel grid.
  double voxel_leaf_m = 0.1;
  /// Neighbourhood radius of the normal estimation (viewpoint at the sensor); ~80 neighbours on a
  /// plane at 0.1 m voxels, and the largest radius that keeps a VLP-16 scan within 20 ms.
  double normal_radius_m = 0.5;
  /// The degenerate-normal filter (horizontal_filter.h) on the keyframe itself. Off by default:
  /// the keyframe also feeds the map and teammates, who need floor and ceiling; the features
  /// apply it for themselves (FeatureParams). Dropping here saves bandwidth instead.
  HorizontalFilter drop_horizontal = HorizontalFilter::kNone;
  double horizontal_normal_z = 0.5;
  /// "2D slice" mode (thesis section 2.2): keep only points whose height above the sensor lies in
  /// [slice_min_z_m, slice_max_z_m] and flatten them to height 0.
  bool slice_mode = false;
  double slice_min_z_m = -0.25;
  double slice_max_z_m = 0.25;
  /// Threads for the normal estimation (0: one per core).
  int threads = 1;
  /// Scans with fewer finite points within range are dropped rather than made keyframes.
  int min_points = 100;
  /// Scans with more points (finite or not) are dropped as they arrive: 2 M is 7x a 128-beam
  /// lidar's scan, and a cloud far beyond it (a merged map replayed on the wrong topic, a
  /// driver bug) would stall the pipeline for seconds.
  int max_points = 2000000;
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
