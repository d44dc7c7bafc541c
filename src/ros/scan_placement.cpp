#include "ccir_mapping/ros/scan_placement.h"

#include <tf2_eigen/tf2_eigen.h>

#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"

namespace ccir_mapping {

ScanPlacement::ScanPlacement(const ros_params::PreprocessorSettings& settings,
                             std::string odometry_topic)
    : from_tf_(settings.odom_source == "tf"),
      odom_frame_(settings.frames.odom_frame),
      base_frame_(settings.frames.base_frame),
      odometry_topic_(std::move(odometry_topic)),
      odom_tolerance_s_(settings.core.odom_tolerance_s) {
  if (settings.odom_source == "lidar") {
    lidar_ = std::make_unique<core::preprocess::LidarOdometry>(settings.lidar_odometry);
  }
}

std::optional<ScanPlacement::Refusal> ScanPlacement::addOdometry(const nav_msgs::Odometry& msg) {
  if (msg.header.frame_id != odom_frame_ || msg.child_frame_id != base_frame_) {
    return Refusal{"in other frames", "'" + msg.header.frame_id + "' -> '" + msg.child_frame_id +
                                          "', expected '" + odom_frame_ + "' -> '" + base_frame_ +
                                          "'"};
  }
  const auto pose = conversions::toPose(msg.pose.pose);
  if (!pose) return Refusal{"pose is not finite", ""};
  if (!odometry_.add(conversions::toStamp(msg.header.stamp), *pose)) {
    return Refusal{"stamp not after the previous one", ""};
  }
  return std::nullopt;
}

bool ScanPlacement::placeable(const std::string& sensor_frame, const ros::Time& stamp,
                              std::string* why) const {
  if (from_tf_) return tf_.canTransform(odom_frame_, sensor_frame, stamp, why);
  if (lidar_) {
    return sensor_frame == base_frame_ ||
           tf_.canTransform(base_frame_, sensor_frame, ros::Time(0), why);
  }
  const auto newest = odometry_.newestStamp();
  if (!newest || conversions::toStamp(stamp) > *newest) {
    if (why) *why = "no odometry at or after its stamp on '" + odometry_topic_ + "'";
    return false;
  }
  return sensor_frame == base_frame_ ||
         tf_.canTransform(base_frame_, sensor_frame, ros::Time(0), why);
}

std::optional<core::Pose3> ScanPlacement::sensorPose(const std::string& sensor_frame,
                                                     const ros::Time& stamp,
                                                     std::string* why) const {
  try {
    if (from_tf_) {
      return tf2::transformToEigen(tf_.lookupTransform(odom_frame_, sensor_frame, stamp));
    }
    const auto base = odometry_.at(conversions::toStamp(stamp), odom_tolerance_s_);
    if (!base) {
      *why = "no odometry within odom_tolerance_s of the scan";
      return std::nullopt;
    }
    const auto sensor_mount = mount(sensor_frame, why);
    if (!sensor_mount) return std::nullopt;
    return *base * *sensor_mount;
  } catch (const tf2::TransformException& e) {
    *why = e.what();
    return std::nullopt;
  }
}

std::optional<core::Pose3> ScanPlacement::mount(const std::string& sensor_frame,
                                                std::string* why) const {
  if (sensor_frame == base_frame_) return core::Pose3::Identity();
  try {
    return tf2::transformToEigen(tf_.lookupTransform(base_frame_, sensor_frame, ros::Time(0)));
  } catch (const tf2::TransformException& e) {
    *why = e.what();
    return std::nullopt;
  }
}

ScanPlacement::Placement ScanPlacement::placeByLidar(
    const sensor_msgs::PointCloud2::ConstPtr& cloud) {
  std::string why;
  const auto sensor_mount = mount(cloud->header.frame_id, &why);
  if (!sensor_mount) return {cloud, std::nullopt, "cannot place it: " + why};
  conversions::toPcl(*cloud, &lidar_scan_);
  const auto tracked = lidar_->track(conversions::toStamp(cloud->header.stamp), lidar_scan_);
  // The odometry frame is base_frame at the first scan: the sensor starts at its mount.
  const core::Pose3 sensor = *sensor_mount * tracked.pose;
  Placement placement{cloud, sensor, ""};
  placement.odometry_tf = conversions::toTransformStampedMsg(
      cloud->header.stamp, odom_frame_, base_frame_, sensor * sensor_mount->inverse());
  placement.notice = tracked.notice;
  return placement;
}

std::vector<ScanPlacement::Placement> ScanPlacement::wait(
    const sensor_msgs::PointCloud2::ConstPtr& cloud) {
  if (cloud->header.frame_id.empty()) {
    return {{cloud, std::nullopt, "cannot place it: it has no frame_id"}};
  }
  std::vector<Placement> placements;
  if (const auto pushed_out = waiting_.push(cloud)) {
    placements.push_back(givenUp(*pushed_out, "waited too long"));
  }
  for (auto& placement : release()) placements.push_back(std::move(placement));
  return placements;
}

std::vector<ScanPlacement::Placement> ScanPlacement::release() {
  std::vector<Placement> placements;
  waiting_.drain(
      [this](const auto& cloud) { return placeable(cloud->header.frame_id, cloud->header.stamp); },
      [&](const auto& cloud) {
        if (lidar_) return placements.push_back(placeByLidar(cloud));
        std::string why;
        const auto pose = sensorPose(cloud->header.frame_id, cloud->header.stamp, &why);
        placements.push_back({cloud, pose, pose ? "" : "cannot place it: " + why});
      },
      [&](const auto& cloud) {
        placements.push_back(givenUp(cloud, "a later scan was placed first"));
      });
  return placements;
}

ScanPlacement::Placement ScanPlacement::givenUp(const sensor_msgs::PointCloud2::ConstPtr& cloud,
                                                const char* context) const {
  std::string why;
  placeable(cloud->header.frame_id, cloud->header.stamp, &why);
  return {cloud, std::nullopt, std::string("cannot place it (") + context + "): " + why};
}

}  // namespace ccir_mapping
