#include "ccir_mapping/core/registration/scan_verifier.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>

#include <pcl/common/transforms.h>
#include <pcl/range_image/range_image.h>
#include <pcl/registration/gicp.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_registration.h>

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

/// PCL's registration model that fits only rigid samples: three correspondences whose pairwise
/// distances differ between the scans by more than twice the inlier distance cannot all be
/// inliers of one rigid transform, so their fit fails at once and RANSAC skips them (up to ten
/// times its iterations) without counting inliers - the pre-rejection of PCL's
/// SampleConsensusPrerejective, which does its own correspondence search and so cannot take
/// ours. A true triple always passes: an iteration is spent only on a plausible draw. Source
/// point i corresponds to target point i (verify() builds them so), so the check reads the
/// target by the sample's index instead of looking each one up in the correspondence map.
class RigidSampleModel : public pcl::SampleConsensusModelRegistration<pcl::PointXYZ> {
 public:
  RigidSampleModel(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& source,
                   const pcl::Indices& indices, double inlier_m)
      : pcl::SampleConsensusModelRegistration<pcl::PointXYZ>(source, indices),
        tolerance_(static_cast<float>(2.0 * inlier_m)) {}

  bool computeModelCoefficients(const pcl::Indices& samples,
                                Eigen::VectorXf& coefficients) const override {
    for (std::size_t a = 0; a < samples.size(); ++a) {
      for (std::size_t b = a + 1; b < samples.size(); ++b) {
        const float in_source =
            ((*input_)[samples[a]].getVector3fMap() - (*input_)[samples[b]].getVector3fMap())
                .norm();
        const float in_target =
            ((*target_)[samples[a]].getVector3fMap() - (*target_)[samples[b]].getVector3fMap())
                .norm();
        if (std::abs(in_source - in_target) > tolerance_) return false;
      }
    }
    return pcl::SampleConsensusModelRegistration<pcl::PointXYZ>::computeModelCoefficients(
        samples, coefficients);
  }

 private:
  float tolerance_;
};

/// PCL's GICP, with its per-point covariances computable ahead: a place's are computed once,
/// not for every candidate it is verified against.
class Gicp : public pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> {
 public:
  void covariancesOf(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                     const PreparedScan::Tree::Ptr& tree, PreparedScan::Covariances& covariances) {
    computeCovariances<pcl::PointXYZ>(cloud, tree, covariances);
  }
};

}  // namespace

double ScanVerifier::freeSpaceViolation(const pcl::PointCloud<pcl::PointXYZ>& to_walls,
                                        const pcl::PointCloud<pcl::PointXYZ>& from_cloud,
                                        const Eigen::Matrix4f& from_to, double margin_m) const {
  const float resolution = pcl::deg2rad(static_cast<float>(params_.range_image_resolution_deg));
  pcl::RangeImage image;
  image.createFromPointCloud(from_cloud, resolution, resolution, pcl::deg2rad(360.0F),
                             pcl::deg2rad(180.0F), Eigen::Affine3f::Identity(),
                             pcl::RangeImage::LASER_FRAME);
  pcl::PointCloud<pcl::PointXYZ> moved;
  pcl::transformPointCloud(to_walls, moved, from_to);
  const auto range2 = static_cast<float>(params_.overlap_range_m * params_.overlap_range_m);
  const auto margin = static_cast<float>(margin_m);
  int seen = 0;
  int violating = 0;
  for (const auto& p : moved) {
    const float r2 = p.getVector3fMap().squaredNorm();
    if (r2 > range2) continue;
    int x = 0;
    int y = 0;
    float range = 0.0F;
    image.getImagePoint(p.getVector3fMap(), x, y, range);
    float nearest = std::numeric_limits<float>::infinity();
    bool agrees = false;
    bool observed = false;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (!image.isValid(x + dx, y + dy)) continue;
        const float r = image.getPoint(x + dx, y + dy).range;
        observed = true;
        agrees |= std::abs(r - range) <= margin;
        nearest = std::min(nearest, r);
      }
    }
    if (!observed) continue;
    if (agrees) {
      ++seen;
    } else if (nearest > range + margin) {
      ++seen;
      ++violating;
    }
  }
  return seen ? static_cast<double>(violating) / seen : 0.0;
}

double ScanVerifier::wallOverlap(const PreparedScan& to, const PreparedScan& from,
                                 const Eigen::Matrix4f& from_to, double distance_m) const {
  if (from.walls->empty()) return 0.0;
  pcl::PointCloud<pcl::PointXYZ> moved;
  pcl::transformPointCloud(*to.walls, moved, from_to);
  const PreparedScan::Tree& tree = *from.walls_tree;
  const auto range2 = static_cast<float>(params_.overlap_range_m * params_.overlap_range_m);
  const auto distance2 = static_cast<float>(distance_m * distance_m);
  int inside = 0;
  int explained = 0;
  pcl::Indices index(1);
  std::vector<float> squared(1);
  for (const auto& p : moved) {
    if (p.getVector3fMap().squaredNorm() > range2) continue;
    ++inside;
    explained += tree.nearestKSearch(p, 1, index, squared) == 1 && squared[0] <= distance2;
  }
  return inside ? static_cast<double>(explained) / inside : 0.0;
}

ScanVerifier::ScanVerifier(const VerificationParams& params) : params_(validated(params)) {}

PreparedScan ScanVerifier::prepare(const pcl::PointCloud<pcl::PointXYZINormal>& cloud,
                                   features::LocalFeatures features,
                                   bool drawn_from_mixture) const {
  pcl::PointCloud<pcl::PointXYZINormal> walls;
  for (const auto& p : cloud) {
    if (std::abs(p.normal_z) < params_.wall_normal_z) walls.push_back(p);
  }
  PreparedScan scan;
  scan.cloud = prepared(cloud, params_.gicp_voxel_m, params_.gicp_max_range_m);
  scan.walls = prepared(walls, params_.gicp_voxel_m, params_.gicp_max_range_m);
  scan.features = std::move(features);
  scan.drawn_from_mixture = drawn_from_mixture;
  complete(scan);
  return scan;
}

void ScanVerifier::compact(PreparedScan& scan) {
  scan.cloud_tree.reset();
  scan.covariances.reset();
  scan.source.reset();
  scan.source_tree.reset();
  scan.source_covariances.reset();
  scan.walls_tree.reset();
}

void ScanVerifier::complete(PreparedScan& scan) const {
  if (isComplete(scan)) return;
  scan.cloud_tree = pcl::make_shared<PreparedScan::Tree>();
  scan.covariances = std::make_shared<PreparedScan::Covariances>();
  auto source = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  scan.source_tree = pcl::make_shared<PreparedScan::Tree>();
  scan.source_covariances = std::make_shared<PreparedScan::Covariances>();
  if (!scan.cloud->empty()) {
    scan.cloud_tree->setInputCloud(scan.cloud);
    if (!scan.packed_covariances) {
      PreparedScan::Covariances estimated;
      Gicp().covariancesOf(scan.cloud, scan.cloud_tree, estimated);
      auto packed = std::make_shared<std::vector<std::array<float, 6>>>();
      packed->reserve(estimated.size());
      for (const auto& c : estimated) {
        packed->push_back({static_cast<float>(c(0, 0)), static_cast<float>(c(0, 1)),
                           static_cast<float>(c(0, 2)), static_cast<float>(c(1, 1)),
                           static_cast<float>(c(1, 2)), static_cast<float>(c(2, 2))});
      }
      scan.packed_covariances = std::move(packed);
    }
    scan.covariances->reserve(scan.packed_covariances->size());
    for (const auto& p : *scan.packed_covariances) {
      Eigen::Matrix3d c;
      c << p[0], p[1], p[2], p[1], p[3], p[4], p[2], p[4], p[5];
      scan.covariances->push_back(c);
    }
    const auto step = static_cast<std::size_t>(params_.gicp_source_step);
    for (std::size_t i = 0; i < scan.cloud->size() && i < scan.covariances->size(); i += step) {
      source->push_back((*scan.cloud)[i]);
      scan.source_covariances->push_back((*scan.covariances)[i]);
    }
    scan.source_tree->setInputCloud(source);
  }
  scan.source = source;
  scan.walls_tree = pcl::make_shared<PreparedScan::Tree>();
  if (!scan.walls->empty()) scan.walls_tree->setInputCloud(scan.walls);
}

Verification ScanVerifier::verify(const PreparedScan& from_scan,
                                  const PreparedScan& to_scan) const {
  if (!isComplete(from_scan) || !isComplete(to_scan)) {
    throw std::invalid_argument("ScanVerifier::verify: a compacted scan (complete() it first)");
  }
  const features::LocalFeatures& from = from_scan.features;
  const features::LocalFeatures& to = to_scan.features;
  Verification v;
  // Correspondences (i in "to", the source moved onto "from"; j in "from"), one point pair each:
  // the sample-consensus model keys pairs by source index, so a keypoint paired several times
  // must appear once per pair. (PCL's CorrespondenceRejectorSampleConsensus is not used: it
  // keeps every correspondence with an identity transform when RANSAC fails.)
  const auto matches =
      features::nearestMatches(to.descriptors, from.descriptors, params_.match_neighbors);
  v.matches = static_cast<int>(matches.size());
  if (v.matches < 3) {
    v.reason = std::to_string(v.matches) + " descriptor correspondences, need 3";
    return v;
  }
  auto source = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto target = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const auto& [i, j] : matches) {
    const Eigen::Vector3f& s = to.keypoints[static_cast<std::size_t>(i)];
    const Eigen::Vector3f& t = from.keypoints[static_cast<std::size_t>(j)];
    source->push_back(pcl::PointXYZ(s.x(), s.y(), s.z()));
    target->push_back(pcl::PointXYZ(t.x(), t.y(), t.z()));
  }
  pcl::Indices pairs(matches.size());
  std::iota(pairs.begin(), pairs.end(), 0);
  auto model = pcl::make_shared<RigidSampleModel>(source, pairs, params_.ransac_inlier_m);
  model->setInputTarget(target, pairs);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, params_.ransac_inlier_m);
  ransac.setMaxIterations(params_.ransac_iterations);
  if (!ransac.computeModel() || !ransac.refineModel()) {
    v.reason = "RANSAC found no transform in " + std::to_string(v.matches) + " correspondences";
    return v;
  }
  pcl::Indices inliers;
  ransac.getInliers(inliers);
  std::set<int> inlier_keypoints;
  for (const int k : inliers) inlier_keypoints.insert(matches[static_cast<std::size_t>(k)].first);
  v.inliers = static_cast<int>(inlier_keypoints.size());
  if (v.inliers < params_.min_inliers) {
    v.reason = std::to_string(v.inliers) + " keypoints agree on a transform, need " +
               std::to_string(params_.min_inliers);
    return v;
  }
  Eigen::VectorXf coefficients;
  ransac.getModelCoefficients(coefficients);
  const Eigen::Matrix4f initial =
      Eigen::Map<const Eigen::Matrix<float, 4, 4, Eigen::RowMajor>>(coefficients.data());
  return refine(from_scan, to_scan, initial, std::move(v));
}

Verification ScanVerifier::verifyFrom(const PreparedScan& from_scan, const PreparedScan& to_scan,
                                      const Pose3& initial) const {
  if (!isComplete(from_scan) || !isComplete(to_scan)) {
    throw std::invalid_argument("ScanVerifier::verifyFrom: a compacted scan (complete() it first)");
  }
  return refine(from_scan, to_scan, initial.matrix().cast<float>(), Verification());
}

Verification ScanVerifier::refine(const PreparedScan& from_scan, const PreparedScan& to_scan,
                                  const Eigen::Matrix4f& initial, Verification v) const {
  // GICP needs a point per covariance neighbourhood in each cloud (its trees and covariances
  // are only made for such clouds).
  for (const PreparedScan* scan : {&from_scan, &to_scan}) {
    if (scan->covariances->size() != scan->cloud->size() || scan->cloud->empty()) {
      v.reason = "a cloud has " + std::to_string(scan->cloud->size()) +
                 " points within gicp_max_range_m, too few to align";
      return v;
    }
  }
  Gicp gicp;
  gicp.setInputSource(to_scan.source);
  gicp.setSourceCovariances(to_scan.source_covariances);
  gicp.setSearchMethodSource(to_scan.source_tree, /*force_no_recompute=*/true);
  gicp.setInputTarget(from_scan.cloud);
  gicp.setTargetCovariances(from_scan.covariances);
  gicp.setSearchMethodTarget(from_scan.cloud_tree, /*force_no_recompute=*/true);
  gicp.setMaxCorrespondenceDistance(params_.gicp_max_correspondence_m);
  gicp.setMaximumIterations(params_.gicp_iterations);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  gicp.align(aligned, initial);
  if (!gicp.hasConverged()) {
    v.reason = "GICP did not converge";
    return v;
  }
  v.fitness_m2 = gicp.getFitnessScore(1.0);
  const Eigen::Matrix4f from_to = gicp.getFinalTransformation();
  v.relative.matrix() = from_to.cast<double>();
  v.covariance = Matrix6::Identity() * std::max(0.01, v.fitness_m2);
  v.covariance.bottomRightCorner<3, 3>() *= 0.1;
  // The cheapest test first, and each test only while it can still decide: most candidates of
  // an aliased mine fail the first or second.
  if (!(v.fitness_m2 <= params_.max_fitness_m2)) {
    v.reason = "GICP fitness " + std::to_string(v.fitness_m2) + " m^2 above " +
               std::to_string(params_.max_fitness_m2);
    return v;
  }
  const bool drawn = from_scan.drawn_from_mixture || to_scan.drawn_from_mixture;
  const double distance_m = drawn ? params_.mixture_overlap_distance_m : params_.overlap_distance_m;
  const double margin_m = drawn ? params_.mixture_free_space_margin_m : params_.free_space_margin_m;
  // Both ways: a scan that sees the mine's outer wall where the other sees a drift fails one.
  v.overlap = wallOverlap(to_scan, from_scan, from_to, distance_m);
  if (v.overlap >= params_.min_overlap) {
    v.overlap = std::min(v.overlap, wallOverlap(from_scan, to_scan, from_to.inverse(), distance_m));
  }
  if (!(v.overlap >= params_.min_overlap)) {
    v.reason = "wall overlap " + std::to_string(v.overlap) + " below " +
               std::to_string(params_.min_overlap);
    return v;
  }
  v.free_space_violation = freeSpaceViolation(*to_scan.walls, *from_scan.cloud, from_to, margin_m);
  if (v.free_space_violation <= params_.max_free_space_violation) {
    v.free_space_violation =
        std::max(v.free_space_violation,
                 freeSpaceViolation(*from_scan.walls, *to_scan.cloud, from_to.inverse(), margin_m));
  }
  if (!(v.free_space_violation <= params_.max_free_space_violation)) {
    v.reason = "free-space violation " + std::to_string(v.free_space_violation) + " above " +
               std::to_string(params_.max_free_space_violation);
    return v;
  }
  v.accepted = true;
  return v;
}

}  // namespace ccir_mapping::core::registration
