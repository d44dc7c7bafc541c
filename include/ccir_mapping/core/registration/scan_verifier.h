// Geometric verification of a place-recognition candidate: RANSAC over nearest spin-image
// correspondences for an initial transform, GICP to refine it, acceptance on inliers and fitness.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/common/serial_kd_tree.h"
#include "ccir_mapping/core/features/local_features.h"

namespace ccir_mapping::core::registration {

struct VerificationParams {
  /// Each keypoint is paired with its this many nearest descriptors in the other scan (both
  /// ways): in a repetitive mine the true partner is often second or third.
  int match_neighbors = 3;
  /// RANSAC (PCL's registration sample-consensus model): inlier distance and iterations.
  double ransac_inlier_m = 0.5;
  int ransac_iterations = 1000;
  /// Distinct keypoints of the candidate scan among the RANSAC inliers.
  int min_inliers = 8;
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
  double range_image_resolution_deg = 1.0;
  /// Points whose unit normal has |z| below this (sensor frame, level sensor) are walls.
  double wall_normal_z = 0.5;

  std::vector<std::string> validate() const;
};

struct Verification {
  bool accepted = false;
  /// Pose of the candidate scan ("to") in the query scan's frame ("from").
  Pose3 relative = Pose3::Identity();
  /// Of `relative`, [x y z, rotation vector]: isotropic, the GICP fitness per axis (floored at
  /// (0.1 m)^2, what sparse 16-beam scans at a 0.2 m voxel support), a tenth of it in rad^2 -
  /// a working approximation, not a GICP Hessian.
  alignment::Matrix6 covariance = alignment::Matrix6::Identity();
  int matches = 0;
  int inliers = 0;
  double fitness_m2 = 0.0;
  /// The wall overlap, the smaller of the two directions (VerificationParams::min_overlap).
  /// Tests run in order (fitness, overlap, free space) and stop at the first that fails, so a
  /// rejected candidate may have the first direction's value only, or 0 for tests not run.
  double overlap = 0.0;
  /// The larger of the two directions' free-space violation shares.
  double free_space_violation = 0.0;
  std::string reason;
};

/// What verification needs of a keyframe, kept for every mapped place: the features and the
/// cloud GICP aligns (cropped, down-sampled, points only: ~15x smaller than the keyframe), with
/// what GICP and the overlap test would otherwise rebuild for every candidate pair: the
/// clouds' search trees and GICP's per-point covariances (~70 bytes a point).
struct PreparedScan {
  using Covariances = std::vector<Eigen::Matrix3d, Eigen::aligned_allocator<Eigen::Matrix3d>>;
  using Tree = common::SerialKdTree<pcl::PointXYZ>;

  pcl::PointCloud<pcl::PointXYZ>::ConstPtr cloud;
  Tree::Ptr cloud_tree;
  std::shared_ptr<Covariances> covariances;
  /// What GICP moves when the scan is the candidate: every gicp_source_step-th point of
  /// `cloud`, with their covariances and tree.
  pcl::PointCloud<pcl::PointXYZ>::ConstPtr source;
  Tree::Ptr source_tree;
  std::shared_ptr<Covariances> source_covariances;
  /// Points on non-horizontal surfaces (walls, pillars, rubble), for the overlap test: floor
  /// and ceiling overlap wherever two scans are aligned, so they would hide a wrong alignment.
  pcl::PointCloud<pcl::PointXYZ>::ConstPtr walls;
  Tree::Ptr walls_tree;
  features::LocalFeatures features;
};

class ScanVerifier {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit ScanVerifier(const VerificationParams& params);

  PreparedScan prepare(const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                       features::LocalFeatures features) const;

  Verification verify(const PreparedScan& from, const PreparedScan& to) const;
  Verification verify(const pcl::PointCloud<pcl::PointXYZINormal>& from_cloud,
                      const features::LocalFeatures& from,
                      const pcl::PointCloud<pcl::PointXYZINormal>& to_cloud,
                      const features::LocalFeatures& to) const {
    return verify(prepare(from_cloud, from), prepare(to_cloud, to));
  }

 private:
  /// Share of `to`'s walls, moved by `from_to`, within overlap_range_m of the origin that lie
  /// within overlap_distance_m of `from`'s walls.
  double wallOverlap(const PreparedScan& to, const PreparedScan& from,
                     const Eigen::Matrix4f& from_to) const;

  /// Share of `to_walls`, moved by `from_to`, within overlap_range_m that `from_cloud`'s range
  /// image shows as free space (VerificationParams::max_free_space_violation).
  double freeSpaceViolation(const pcl::PointCloud<pcl::PointXYZ>& to_walls,
                            const pcl::PointCloud<pcl::PointXYZ>& from_cloud,
                            const Eigen::Matrix4f& from_to) const;

  VerificationParams params_;
};

}  // namespace ccir_mapping::core::registration
