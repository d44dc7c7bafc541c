#include "ccir_mapping/core/preprocess/lidar_odometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <pcl/common/transforms.h>
#include <pcl/registration/gicp.h>

#include "ccir_mapping/core/preprocess/voxel_downsample.h"

namespace ccir_mapping::core::preprocess {
namespace {

/// Fewer points than this give GICP too little to hold on to.
constexpr std::size_t kMinRegistrationPoints = 50;
/// The constant-velocity prediction extrapolates at most this many scan intervals (a gap of
/// missed scans); beyond, the robot may have stopped.
constexpr double kMaxPredictionIntervals = 3.0;
/// The correspondence gate of the coarse pass, times max_correspondence_m.
constexpr double kCoarseGate = 4.0;

}  // namespace

class LidarOdometry::Registration {
 public:
  explicit Registration(const LidarOdometryParams& params) {
    gicp_.setMaximumIterations(params.max_iterations);
  }
  void setLocalMap(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& map) {
    gicp_.setInputTarget(map);  // its covariances are computed once, at the next alignment
    map_size_ = map->size();
  }
  /// The scan's pose in the local map's frame from `guess`, and the fit's mean squared distance.
  std::pair<Pose3, double> align(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& scan,
                                 const Pose3& guess, double max_correspondence_m) {
    gicp_.setMaxCorrespondenceDistance(max_correspondence_m);
    gicp_.setInputSource(scan);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    gicp_.align(aligned, guess.matrix().cast<float>());
    Pose3 pose(gicp_.getFinalTransformation().cast<double>());
    pose.linear() = Eigen::Quaterniond(pose.rotation()).normalized().toRotationMatrix();
    const double fitness = gicp_.hasConverged()
                               ? gicp_.getFitnessScore(max_correspondence_m * max_correspondence_m)
                               : std::numeric_limits<double>::infinity();
    return {pose, fitness};
  }
  std::size_t mapSize() const { return map_size_; }

 private:
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp_;
  std::size_t map_size_ = 0;
};

LidarOdometry::LidarOdometry(const LidarOdometryParams& params) : params_(params) {
  if (const auto errors = params.validate(); !errors.empty()) {
    throw std::invalid_argument("invalid lidar odometry parameter: " + errors.front());
  }
  registration_ = std::make_unique<Registration>(params_);
}

LidarOdometry::~LidarOdometry() = default;

std::size_t LidarOdometry::localMapPoints() const { return registration_->mapSize(); }

Pose3 LidarOdometry::predict(Stamp stamp) const {
  if (!last_) return Pose3::Identity();
  if (!before_last_ || last_->stamp <= before_last_->stamp) return last_->pose;
  const Pose3 delta = before_last_->pose.inverse() * last_->pose;
  const double intervals = std::clamp(static_cast<double>(stamp - last_->stamp) /
                                          static_cast<double>(last_->stamp - before_last_->stamp),
                                      0.0, kMaxPredictionIntervals);
  Eigen::AngleAxisd rotation(delta.rotation());
  rotation.angle() *= intervals;
  Pose3 scaled = Pose3::Identity();
  scaled.linear() = rotation.toRotationMatrix();
  scaled.translation() = delta.translation() * intervals;
  return last_->pose * scaled;
}

LidarOdometry::Result LidarOdometry::track(Stamp stamp, const Cloud& scan) {
  Result result;
  if (last_ && stamp <= last_->stamp) {
    result.pose = last_->pose;
    result.notice = Notice{"lidar odometry stamp",
                           "lidar odometry: the scan's stamp is not after the previous scan's; "
                           "placed at the previous scan's pose"};
    return result;
  }
  pcl::PointCloud<pcl::PointXYZ> cropped;
  cropped.reserve(scan.size());
  const float min_range2 = static_cast<float>(params_.min_range_m * params_.min_range_m);
  for (const auto& p : scan) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    if (p.x * p.x + p.y * p.y + p.z * p.z < min_range2) continue;
    cropped.push_back(pcl::PointXYZ(p.x, p.y, p.z));
  }
  const pcl::PointCloud<pcl::PointXYZ>::Ptr points = voxelDownsample(cropped, params_.voxel_m);

  result.pose = predict(stamp);
  if (points->size() < kMinRegistrationPoints) {
    result.notice = Notice{"lidar odometry points",
                           "lidar odometry: " + std::to_string(points->size()) +
                               " points after the crop and voxel grid, too few to register; "
                               "placed by the motion prediction"};
  } else if (local_scans_.empty()) {
    result.registered = true;  // the first scan defines the odometry frame
  } else {
    // Without a velocity yet (the second scan) the prediction is "not moving": a coarse pass
    // with a wider gate first reaches a robot that already drives.
    Pose3 guess = result.pose;
    if (!before_last_) {
      guess = registration_->align(points, guess, kCoarseGate * params_.max_correspondence_m).first;
    }
    const auto [pose, fitness] = registration_->align(points, guess, params_.max_correspondence_m);
    result.fitness_m2 = fitness;
    if (fitness <= params_.max_fitness_m2) {
      result.pose = pose;
      result.registered = true;
    } else {
      result.notice =
          Notice{"lidar odometry fit", "lidar odometry: GICP fitted the local map badly (mean " +
                                           std::to_string(fitness) +
                                           " m^2 > lidar_max_fitness_m2); "
                                           "placed by the motion prediction"};
    }
  }
  before_last_ = last_;
  last_ = Placed{stamp, result.pose};
  if (result.registered) addToLocalMap(*points, result.pose);
  return result;
}

void LidarOdometry::addToLocalMap(const pcl::PointCloud<pcl::PointXYZ>& scan, const Pose3& pose) {
  if (last_local_map_pose_) {
    const Pose3 moved = last_local_map_pose_->inverse() * pose;
    const double turned_deg = Eigen::AngleAxisd(moved.rotation()).angle() * 180.0 / M_PI;
    if (moved.translation().norm() < params_.local_map_step_m &&
        turned_deg < params_.local_map_step_deg) {
      return;
    }
  }
  last_local_map_pose_ = pose;
  auto placed = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl::transformPointCloud(scan, *placed, pose.matrix().cast<float>());
  local_scans_.push_back(placed);
  while (local_scans_.size() > static_cast<std::size_t>(params_.local_map_scans)) {
    local_scans_.pop_front();
  }
  pcl::PointCloud<pcl::PointXYZ> merged;
  for (const auto& cloud : local_scans_) merged += *cloud;
  registration_->setLocalMap(voxelDownsample(merged, params_.voxel_m));
}

}  // namespace ccir_mapping::core::preprocess
