// When two scans are taken to show one place (ScanVerifier): the matching, RANSAC and GICP
// settings and the acceptance tests. The Matcher's parameters nest these.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::registration {

struct VerificationParams {
  /// Each keypoint is paired with its this many nearest descriptors in the other scan (both
  /// ways): in a repetitive mine the true partner is often second or third.
  int match_neighbors = 3;
  /// RANSAC (PCL's registration sample-consensus model): inlier distance and iterations.
  double ransac_inlier_m = 0.5;
  int ransac_iterations = 1000;
  /// Distinct keypoints of the candidate scan among the RANSAC inliers (few: the wall overlap
  /// and free-space tests below judge the alignment).
  int min_inliers = 5;
  /// GICP on the two clouds, down-sampled to this voxel and cropped to this range.
  double gicp_voxel_m = 0.2;
  double gicp_max_range_m = 40.0;
  double gicp_max_correspondence_m = 1.0;
  int gicp_iterations = 50;
  /// GICP moves every this-th point of the candidate's cloud onto all of the other's: six
  /// degrees of freedom need far fewer than a keyframe's ~5000, and the cost is proportional.
  int gicp_source_step = 2;
  /// Accept when the mean squared distance of matched points (within 1 m) is at most this.
  double max_fitness_m2 = 0.1;
  /// ... and when, after alignment, at least this share of each scan's wall points within
  /// overlap_range_m of the other's sensor lie within overlap_distance_m of the other's walls.
  /// In a repetitive mine a place one pillar away also fits well locally, but its far walls,
  /// pillar sizes and rubble do not.
  double min_overlap = 0.6;
  double overlap_distance_m = 0.1;
  double overlap_range_m = 30.0;
  /// ... and when at most this share of either scan's wall points (within overlap_range_m)
  /// lie where the other scan saw through them: in the other's range image (this resolution)
  /// every return around that direction is farther by more than free_space_margin_m. Points
  /// the other could not see count for neither side, so a change of viewpoint passes; a pillar
  /// face or rubble box the other place lacks, or a wall decimetres off, does not.
  double max_free_space_violation = 0.01;
  double free_space_margin_m = 0.15;
  /// The two distances above when either scan was drawn from a Gaussian mixture (a teammate's
  /// scan_encoding gmm): its points spread over each Gaussian instead of lying on the sensor's
  /// rings, so few fall within 0.1 m of the other scan's ring points even at the true pose
  /// (a simulated mine: overlap 0.3-0.57). Chosen on missions 56-58: 0.15 m verifies 5 % fewer
  /// true places than 0.2 m with 15 false ones instead of 27.
  double mixture_overlap_distance_m = 0.15;
  double mixture_free_space_margin_m = 0.3;
  double range_image_resolution_deg = 1.0;
  /// Points whose unit normal has |z| below this (sensor frame, level sensor) are walls.
  double wall_normal_z = 0.5;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::registration
