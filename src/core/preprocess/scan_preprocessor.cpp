#include "ccir_mapping/core/preprocess/scan_preprocessor.h"

#include <cmath>
#include <stdexcept>

#include <pcl/features/normal_3d_omp.h>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/common/serial_kd_tree.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"

namespace ccir_mapping::core::preprocess {

ScanPreprocessor::ScanPreprocessor(const PreprocessorParams& params) : params_(validated(params)) {}

namespace {

/// Finite, not the driver's zero "no return" point, and within [min, max] range.
bool inRange(const pcl::PointXYZI& p, double min2, double max2, PreprocessStats& s) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) ||
      (p.x == 0.0F && p.y == 0.0F && p.z == 0.0F)) {
    ++s.not_finite;
    return false;
  }
  const double r2 = static_cast<double>(p.x) * p.x + static_cast<double>(p.y) * p.y +
                    static_cast<double>(p.z) * p.z;
  if (r2 < min2 || r2 > max2) {
    ++s.out_of_range;
    return false;
  }
  return true;
}

}  // namespace

std::size_t ScanPreprocessor::usablePoints(const InputCloud& scan, PreprocessStats* stats) const {
  PreprocessStats local;
  PreprocessStats& s = stats ? *stats : local;
  s = PreprocessStats{};
  s.points_in = scan.size();
  const double min2 = params_.min_range_m * params_.min_range_m;
  const double max2 = params_.max_range_m * params_.max_range_m;
  std::size_t usable = 0;
  for (const auto& p : scan) usable += inRange(p, min2, max2, s);
  return usable;
}

ScanPreprocessor::OutputCloud::Ptr ScanPreprocessor::process(const InputCloud& scan,
                                                             const Eigen::Vector3f& up,
                                                             PreprocessStats* stats) const {
  PreprocessStats local;
  PreprocessStats& s = stats ? *stats : local;
  s = PreprocessStats{};
  s.points_in = scan.size();

  // Range crop; drops NaN and the zero points some drivers write for "no return".
  const double min2 = params_.min_range_m * params_.min_range_m;
  const double max2 = params_.max_range_m * params_.max_range_m;
  InputCloud cropped;
  cropped.reserve(scan.size());
  for (const auto& p : scan) {
    if (!inRange(p, min2, max2, s)) continue;
    pcl::PointXYZI q = p;
    if (!std::isfinite(q.intensity)) q.intensity = 0.0F;
    cropped.push_back(q);
  }
  auto out = pcl::make_shared<OutputCloud>();
  out->header = scan.header;
  if (cropped.empty()) return out;

  const InputCloud::Ptr voxels = voxelDownsample(cropped, params_.voxel_leaf_m);
  s.voxels = voxels->size();

  pcl::NormalEstimationOMP<pcl::PointXYZI, pcl::Normal> estimation(
      static_cast<unsigned int>(params_.threads));
  estimation.setInputCloud(voxels);
  // Unsorted neighbours: sorting each result costs a third of the normal estimation.
  estimation.setSearchMethod(std::make_shared<common::SerialKdTree<pcl::PointXYZI>>(false));
  estimation.setRadiusSearch(params_.normal_radius_m);
  estimation.setViewPoint(0.0F, 0.0F, 0.0F);  // the sensor: normals face it
  pcl::PointCloud<pcl::Normal> normals;
  estimation.compute(normals);

  out->reserve(voxels->size());
  for (std::size_t i = 0; i < voxels->size(); ++i) {
    const auto& p = (*voxels)[i];
    const auto& n = normals[i];
    const Eigen::Vector3f normal(n.normal_x, n.normal_y, n.normal_z);
    if (!normal.allFinite() || std::abs(normal.norm() - 1.0F) > 1e-3F) {
      ++s.without_normal;  // too few neighbours for a plane fit
      continue;
    }
    const Eigen::Vector3f position(p.x, p.y, p.z);
    if (dropsAsHorizontal(params_.drop_horizontal, params_.horizontal_normal_z, position, normal,
                          up)) {
      ++s.horizontal;
      continue;
    }
    const float height = position.dot(up);
    Eigen::Vector3f kept = position;
    if (params_.slice_mode) {
      if (height < params_.slice_min_z_m || height > params_.slice_max_z_m) {
        ++s.outside_slice;
        continue;
      }
      kept -= height * up;  // flatten onto the sensor's horizontal plane
    }
    pcl::PointXYZINormal q;
    q.x = kept.x();
    q.y = kept.y();
    q.z = kept.z();
    q.intensity = p.intensity;
    q.normal_x = normal.x();
    q.normal_y = normal.y();
    q.normal_z = normal.z();
    q.curvature = std::isfinite(n.curvature) ? n.curvature : 0.0F;
    out->push_back(q);
  }
  out->is_dense = true;
  s.points_out = out->size();
  return out;
}

}  // namespace ccir_mapping::core::preprocess
