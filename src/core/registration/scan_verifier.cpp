#include "ccir_mapping/core/registration/scan_verifier.h"

#include <cmath>
#include <stdexcept>

#include <pcl/registration/correspondence_rejection_sample_consensus.h>
#include <pcl/registration/gicp.h>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/features/descriptor_matcher.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"

namespace ccir_mapping::core::registration {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr prepared(const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                             double voxel_m, double max_range_m) {
  pcl::PointCloud<pcl::PointXYZ> cropped;
  const float max2 = static_cast<float>(max_range_m * max_range_m);
  for (const auto& p : cloud) {
    if (p.getVector3fMap().allFinite() && p.getVector3fMap().squaredNorm() <= max2) {
      cropped.push_back(pcl::PointXYZ(p.x, p.y, p.z));
    }
  }
  return preprocess::voxelDownsample(cropped, voxel_m);
}

pcl::PointCloud<pcl::PointXYZ>::Ptr keypoints(const features::LocalFeatures& features) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const auto& k : features.keypoints) cloud->push_back(pcl::PointXYZ(k.x(), k.y(), k.z()));
  return cloud;
}

}  // namespace

std::vector<std::string> VerificationParams::validate() const {
  ParamCheck check;
  check.inHalfOpenRange("match_ratio", match_ratio, 0.0, 1.0);
  check.inHalfOpenRange("ransac_inlier_m", ransac_inlier_m, 0.0, 100.0);
  check.inRange("ransac_iterations", ransac_iterations, 1, 1000000);
  check.inRange("min_inliers", min_inliers, 3, 100000);
  check.inHalfOpenRange("gicp_voxel_m", gicp_voxel_m, 0.0, 10.0);
  check.inHalfOpenRange("gicp_max_range_m", gicp_max_range_m, 0.0, 300.0);
  check.inHalfOpenRange("gicp_max_correspondence_m", gicp_max_correspondence_m, 0.0, 100.0);
  check.inRange("gicp_iterations", gicp_iterations, 1, 10000);
  check.inHalfOpenRange("max_fitness_m2", max_fitness_m2, 0.0, 100.0);
  return check.errors();
}

ScanVerifier::ScanVerifier(const VerificationParams& params) : params_(params) {
  const auto errors = params.validate();
  if (!errors.empty()) throw std::invalid_argument(errors.front());
}

Verification ScanVerifier::verify(const pcl::PointCloud<pcl::PointXYZINormal>& from_cloud,
                                  const features::LocalFeatures& from,
                                  const pcl::PointCloud<pcl::PointXYZINormal>& to_cloud,
                                  const features::LocalFeatures& to) const {
  Verification v;
  // Correspondences: index_query in "to" (the source moved onto "from"), index_match in "from".
  const auto matches =
      features::mutualMatches(to.descriptors, from.descriptors, params_.match_ratio);
  v.matches = static_cast<int>(matches.size());
  if (v.matches < params_.min_inliers) {
    v.reason = std::to_string(v.matches) + " mutual descriptor matches, need " +
               std::to_string(params_.min_inliers);
    return v;
  }
  auto correspondences = pcl::make_shared<pcl::Correspondences>();
  for (const auto& [i, j] : matches) correspondences->emplace_back(i, j, 0.0F);
  pcl::registration::CorrespondenceRejectorSampleConsensus<pcl::PointXYZ> ransac;
  ransac.setInputSource(keypoints(to));
  ransac.setInputTarget(keypoints(from));
  ransac.setInlierThreshold(params_.ransac_inlier_m);
  ransac.setMaximumIterations(params_.ransac_iterations);
  ransac.setRefineModel(true);
  ransac.setInputCorrespondences(correspondences);
  pcl::Correspondences inliers;
  ransac.getCorrespondences(inliers);
  v.inliers = static_cast<int>(inliers.size());
  if (v.inliers < params_.min_inliers) {
    v.reason = std::to_string(v.inliers) + " RANSAC inliers of " + std::to_string(v.matches) +
               " matches, need " + std::to_string(params_.min_inliers);
    return v;
  }
  const Eigen::Matrix4f initial = ransac.getBestTransformation();

  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setInputSource(prepared(to_cloud, params_.gicp_voxel_m, params_.gicp_max_range_m));
  gicp.setInputTarget(prepared(from_cloud, params_.gicp_voxel_m, params_.gicp_max_range_m));
  gicp.setMaxCorrespondenceDistance(params_.gicp_max_correspondence_m);
  gicp.setMaximumIterations(params_.gicp_iterations);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  gicp.align(aligned, initial);
  if (!gicp.hasConverged()) {
    v.reason = "GICP did not converge";
    return v;
  }
  v.fitness_m2 = gicp.getFitnessScore(1.0);
  v.relative.matrix() = gicp.getFinalTransformation().cast<double>();
  const double variance = std::max(1e-4, v.fitness_m2 / v.inliers);
  v.covariance = alignment::Matrix6::Identity() * variance;
  v.covariance.bottomRightCorner<3, 3>() *= 0.1;  // radians: ~0.3 rad per metre of spread
  if (!(v.fitness_m2 <= params_.max_fitness_m2)) {
    v.reason = "GICP fitness " + std::to_string(v.fitness_m2) + " m^2 above " +
               std::to_string(params_.max_fitness_m2);
    return v;
  }
  v.accepted = true;
  return v;
}

}  // namespace ccir_mapping::core::registration
