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
  /// Scans go into submaps of this many consecutive scans of one robot (own keyframes, or one
  /// teammate's scans): blocks of occupancy evidence that the map moves as a whole when the
  /// optimised poses move (see SubmapSet).
  int submap_scans = 10;
  /// A submap is re-anchored (its evidence moved to where its first scan now is) when that scan's
  /// optimised pose, or a team transform, has moved more than this since it was last placed; it
  /// is re-integrated (its scans inserted again) when a scan moved this much relative to the
  /// first one, while it still holds its clouds.
  double reanchor_shift_m = 0.2;
  double reanchor_rotation_deg = 1.0;
  /// After following moved poses the Mapper waits this long per million voxels the follow
  /// visited (SubmapSet::lastVisited: the moved submaps' own, those of the submaps it gathered
  /// from, the map's recomputed; 0: no wait). A follow's CPU time follows that count at ~0.06 s
  /// per million (0.058 - 0.064 over the follows of an 8-minute three-robot mission, where the
  /// map's voxels alone varied 0.33 - 0.54 s per million), so following takes at most
  /// ~0.06 / (0.06 + this) of a core (~15 % at 0.35) while the moves of the solves meanwhile
  /// gather; without a wait it follows every solve at once.
  double reanchor_wait_s_per_mvoxel_visited = 0.35;
  /// The newest this many placed scans are in live submaps, which follow corrections and keep
  /// their clouds (~0.1-0.3 MB a scan) and evidence (~1 MB a scan at 0.1 m: a scan's rays cross
  /// ~150 k voxels, few shared with the next scan's). Once a quarter more are placed, the oldest
  /// closed submaps settle: their evidence joins the settled part of the map (8 bytes a voxel,
  /// counted once however often seen), their clouds are released, and they stay where they
  /// last were. So memory and the cost of a move stay bounded however long the mission; the
  /// price is that a correction reaching a settled scan no longer moves it. 0: none settles.
  int submap_window_scans = 60;
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
