#include "ccir_mapping/core/features/feature_extractor.h"

#include <cmath>
#include <numeric>
#include <stdexcept>

#include <pcl/features/normal_3d.h>
#include <pcl/features/spin_image.h>
#include <pcl/keypoints/iss_3d.h>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/common/serial_kd_tree.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"

namespace ccir_mapping::core::features {

using Cloud = pcl::PointCloud<pcl::PointXYZINormal>;

FeatureExtractor::FeatureExtractor(const FeatureParams& params) : params_(validated(params)) {}

LocalFeatures FeatureExtractor::extract(const Cloud& cloud, const Eigen::Vector3f& up,
                                        ExtractionStats* stats) const {
  ExtractionStats local;
  ExtractionStats& s = stats ? *stats : local;
  s = ExtractionStats{};
  LocalFeatures features;

  // Range crop and the coarser voxel grid, then normals at this scale (the keyframe's are
  // estimated for its finer grid), then the degenerate-normal filter.
  pcl::PointCloud<pcl::PointXYZ> cropped;
  const float max2 = static_cast<float>(params_.max_range_m * params_.max_range_m);
  for (const auto& p : cloud) {
    if (p.getVector3fMap().allFinite() && p.getVector3fMap().squaredNorm() <= max2) {
      cropped.push_back(pcl::PointXYZ(p.x, p.y, p.z));
    }
  }
  const pcl::PointCloud<pcl::PointXYZ>::Ptr points =
      params_.voxel_m > 0.0 ? preprocess::voxelDownsample(cropped, params_.voxel_m)
                            : pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>(cropped);
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
  estimation.setInputCloud(points);
  estimation.setSearchMethod(std::make_shared<common::SerialKdTree<pcl::PointXYZ>>(false));
  estimation.setRadiusSearch(params_.normal_radius_m);
  estimation.setViewPoint(0.0F, 0.0F, 0.0F);
  pcl::PointCloud<pcl::Normal> normals;
  estimation.compute(normals);

  auto surface = pcl::make_shared<Cloud>();
  for (std::size_t i = 0; i < points->size(); ++i) {
    const Eigen::Vector3f position = (*points)[i].getVector3fMap();
    const Eigen::Vector3f normal = normals[i].getNormalVector3fMap();
    if (!normal.allFinite() ||
        preprocess::dropsAsHorizontal(params_.drop_horizontal, params_.horizontal_normal_z,
                                      position, normal, up)) {
      continue;
    }
    pcl::PointXYZINormal q;
    q.getVector3fMap() = position;
    q.getNormalVector3fMap() = normal.normalized();
    surface->push_back(q);
  }
  s.points = surface->size();
  if (surface->size() < static_cast<std::size_t>(params_.iss_min_neighbors) + 1) return features;

  auto tree = std::make_shared<common::SerialKdTree<pcl::PointXYZINormal>>(false);
  tree->setInputCloud(surface);

  // ISS on the same cloud it searches (a different search surface breaks its NMS in 1.13).
  pcl::ISSKeypoint3D<pcl::PointXYZINormal, pcl::PointXYZINormal, pcl::PointXYZINormal> iss;
  iss.setInputCloud(surface);
  iss.setSearchMethod(tree);
  iss.setSalientRadius(params_.iss_salient_radius_m);
  iss.setNonMaxRadius(params_.iss_non_max_radius_m);
  iss.setThreshold21(params_.iss_gamma_21);
  iss.setThreshold32(params_.iss_gamma_32);
  iss.setMinNeighbors(params_.iss_min_neighbors);
  iss.setBorderRadius(0.0);
  iss.setNumberOfThreads(1);
  pcl::PointCloud<pcl::PointXYZINormal> keypoints;
  iss.compute(keypoints);
  const pcl::PointIndicesConstPtr keypoint_indices = iss.getKeypointsIndices();
  s.keypoints = keypoint_indices->indices.size();

  // A spin image of a sparse support describes nothing: leave such keypoints out.
  pcl::Indices described;
  pcl::Indices neighbours;
  std::vector<float> distances;
  for (const auto index : keypoint_indices->indices) {
    if (index < 0 || static_cast<std::size_t>(index) >= surface->size()) continue;
    if (tree->radiusSearch((*surface)[index], params_.spin_support_m, neighbours, distances) >=
        params_.spin_min_neighbors) {
      described.push_back(index);
    } else {
      ++s.sparse;
    }
  }
  if (described.empty()) return features;

  const auto images = describe(surface, described, up);
  // Places keep their features for the whole mission: grown by push_back, 175 spin images took
  // room for 256.
  features.keypoints.reserve(images.size());
  features.descriptors.reserve(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (!images[i]) {
      ++s.degenerate;
      continue;
    }
    features.keypoints.push_back((*surface)[described[i]].getVector3fMap());
    features.descriptors.push_back(*images[i]);
  }
  s.descriptors = features.size();
  return features;
}

std::vector<std::optional<SpinImage>> FeatureExtractor::describe(const Cloud::ConstPtr& surface,
                                                                 const pcl::Indices& at,
                                                                 const Eigen::Vector3f& up) const {
  std::vector<std::optional<SpinImage>> result(at.size());
  if (at.empty()) return result;
  // Computed on the whole cloud with the points as indices (PCL 1.13 rejects them as input with
  // a separate search surface). Every point has itself as a neighbour: PCL never throws on a
  // sparse support, it returns an empty image, which is reported as nullopt.
  pcl::SpinImageEstimation<pcl::PointXYZINormal, pcl::PointXYZINormal,
                           pcl::Histogram<kSpinImageBins>>
      spin(kSpinImageWidth, 0.0, 1);
  spin.setInputCloud(surface);
  spin.setInputNormals(surface);
  spin.setIndices(pcl::make_shared<pcl::Indices>(at));
  spin.setSearchMethod(std::make_shared<common::SerialKdTree<pcl::PointXYZINormal>>(false));
  spin.setRadiusSearch(params_.spin_support_m);
  if (params_.spin_axis == SpinAxis::kZUp) {
    pcl::PointXYZINormal axis;
    axis.getNormalVector3fMap() = up.normalized();
    spin.setRotationAxis(axis);
  } else {
    spin.useNormalsAsRotationAxis();
  }
  pcl::PointCloud<pcl::Histogram<kSpinImageBins>> images;
  spin.compute(images);
  for (std::size_t i = 0; i < at.size() && i < images.size(); ++i) {
    SpinImage image;
    std::copy(std::begin(images[i].histogram), std::end(images[i].histogram), image.begin());
    const bool finite =
        std::all_of(image.begin(), image.end(), [](float v) { return std::isfinite(v); });
    if (finite && std::accumulate(image.begin(), image.end(), 0.0F) > 0.0F) result[i] = image;
  }
  return result;
}

}  // namespace ccir_mapping::core::features
