// Geometric verification of a place-recognition candidate: RANSAC over nearest spin-image
// correspondences for an initial transform, GICP to refine it, acceptance on inliers and fitness.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/serial_kd_tree.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/features/local_features.h"
#include "ccir_mapping/core/registration/verification_params.h"

namespace ccir_mapping::core::registration {

struct Verification {
  bool accepted = false;
  /// Pose of the candidate scan ("to") in the query scan's frame ("from").
  Pose3 relative = Pose3::Identity();
  /// Of `relative`, [x y z, rotation vector]: isotropic, the GICP fitness per axis (floored at
  /// (0.1 m)^2, what sparse 16-beam scans at a 0.2 m voxel support), a tenth of it in rad^2 -
  /// a working approximation, not a GICP Hessian.
  Matrix6 covariance = Matrix6::Identity();
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
  /// GICP's covariances of `cloud` in single precision, upper triangles (24 bytes a point, a
  /// third of the double ones): compact() keeps them, so complete() only rebuilds the search
  /// trees, and the double ones are always made from these, so a scan completed again verifies
  /// exactly as it did before.
  std::shared_ptr<const std::vector<std::array<float, 6>>> packed_covariances;
  /// Points on non-horizontal surfaces (walls, pillars, rubble), for the overlap test: floor
  /// and ceiling overlap wherever two scans are aligned, so they would hide a wrong alignment.
  pcl::PointCloud<pcl::PointXYZ>::ConstPtr walls;
  Tree::Ptr walls_tree;
  features::LocalFeatures features;
  /// Drawn from a Gaussian mixture, not measured (VerificationParams::mixture_*).
  bool drawn_from_mixture = false;
};

class ScanVerifier {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit ScanVerifier(const VerificationParams& params);

  PreparedScan prepare(const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                       features::LocalFeatures features, bool drawn_from_mixture = false) const;
  /// What a prepared scan keeps while it waits (its clouds, features and packed covariances,
  /// ~1/5 of it): the search trees, double covariances and GICP source go, and complete() makes
  /// them again without estimating a covariance.
  static void compact(PreparedScan& scan);
  static bool isComplete(const PreparedScan& scan) { return scan.cloud_tree != nullptr; }
  void complete(PreparedScan& scan) const;

  Verification verify(const PreparedScan& from, const PreparedScan& to) const;
  /// The same tests from a transform found otherwise (a mixture registration): GICP starts from
  /// `initial` (pose of "to" in "from"); no descriptors are compared (matches, inliers 0).
  Verification verifyFrom(const PreparedScan& from, const PreparedScan& to,
                          const Pose3& initial) const;
  Verification verify(const pcl::PointCloud<pcl::PointXYZINormal>& from_cloud,
                      const features::LocalFeatures& from,
                      const pcl::PointCloud<pcl::PointXYZINormal>& to_cloud,
                      const features::LocalFeatures& to) const {
    return verify(prepare(from_cloud, from), prepare(to_cloud, to));
  }

 private:
  /// Share of `to`'s walls, moved by `from_to`, within overlap_range_m of the origin that lie
  /// within `distance_m` of `from`'s walls.
  double wallOverlap(const PreparedScan& to, const PreparedScan& from,
                     const Eigen::Matrix4f& from_to, double distance_m) const;

  /// Share of `to_walls`, moved by `from_to`, within overlap_range_m that `from_cloud`'s range
  /// image shows as free space beyond `margin_m` (VerificationParams::max_free_space_violation).
  double freeSpaceViolation(const pcl::PointCloud<pcl::PointXYZ>& to_walls,
                            const pcl::PointCloud<pcl::PointXYZ>& from_cloud,
                            const Eigen::Matrix4f& from_to, double margin_m) const;

  /// GICP from `initial`, then the fitness, overlap and free-space tests.
  Verification refine(const PreparedScan& from, const PreparedScan& to,
                      const Eigen::Matrix4f& initial, Verification v) const;

  VerificationParams params_;
};

}  // namespace ccir_mapping::core::registration
