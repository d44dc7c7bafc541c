// Parameters of the distributed occupancy map.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace ccir_mapping::core::information {

struct MapperParams {
  /// OctoMap leaf size.
  double resolution_m = 0.1;
  /// Beams are integrated up to this range (longer ones clear free space only up to it).
  double max_insert_range_m = 30.0;
  /// Occupancy probabilities are clamped to [occupancy_clamp_min, occupancy_clamp_max] (OctoMap's
  /// own 0.12 / 0.97 leave a mapped free corridor so uncertain that a beam through it still
  /// looks informative; these take ~11 misses or ~6 hits to reach).
  double occupancy_clamp_min = 0.01;
  double occupancy_clamp_max = 0.99;
  /// Range noise of the beam model in the mutual information (CSQMI).
  double csqmi_sigma_m = 0.03;
  /// Simulated VLP-16 measurements (the information of an offered scan): 16 rings, one beam
  /// every this many degrees of azimuth.
  double simulated_azimuth_step_deg = 3.0;
  /// Mutual information of a real scan: one beam per this many of its points.
  int scan_beam_step = 10;
  /// The map is rebuilt when an inserted keyframe's optimised pose, or a team transform, has
  /// moved more than this since it was inserted.
  double rebuild_shift_m = 0.2;
  double rebuild_rotation_deg = 1.0;
  /// A rebuild waits this long per scan the last one placed (0: none): it costs ~60 ms of CPU
  /// per scan, so with a wait rebuilds take at most ~60 ms / this of a core (~25 % at 0.25);
  /// without one they run back to back while the optimised poses keep moving (a 300 s 3-robot
  /// mission: 811 of a robot's 1023 CPU seconds). With rebuild_window_scans 400 a correction
  /// shows within ~100 s.
  double rebuild_wait_s_per_scan = 0.25;
  /// Rebuilds re-place only the newest this many placed scans (own and teammates', in the order
  /// they were placed). Once a quarter window more are placed, the older ones are settled:
  /// integrated once more, at their poses of that moment, into a compact base map (see
  /// OccupancyMap::Snapshot) that every rebuild starts from, and their clouds released. So a
  /// rebuild costs at most this many scans and a robot keeps at most 1.25 times this many
  /// clouds, however long the mission; the price is that a correction reaching a settled scan
  /// no longer moves it in the map. 400: a 3-robot mission reaches it after ~4 minutes (each
  /// robot ~1 keyframe/s and ~0.6 teammates' scans/s); a rebuild then costs at most ~25 s of
  /// CPU and the clouds ~90 MB. 0: no window (every scan kept and re-placed).
  int rebuild_window_scans = 400;
  /// Map entropy and known volume are reported over this box around the map origin (fixed, so
  /// the numbers compare over time).
  double entropy_box_half_width_m = 100.0;
  double entropy_box_min_z_m = -5.0;
  double entropy_box_max_z_m = 10.0;
  /// Period of map statistics and visualisation output.
  double publish_period_s = 2.0;

  std::vector<std::string> validate() const;
  /// The entropy box.
  Eigen::Vector3d entropyBoxMin() const;
  Eigen::Vector3d entropyBoxMax() const;
};

}  // namespace ccir_mapping::core::information
