#include "ccir_mapping/ros/conversions.h"

#include <cmath>
#include <string_view>

#include <sensor_msgs/PointField.h>
#include <tf2_eigen/tf2_eigen.h>

namespace ccir_mapping::conversions {
namespace {

template <class Quaternion>
bool isUnitQuaternion(const Quaternion& q) {
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  return std::isfinite(norm2) && std::abs(norm2 - 1.0) < 1e-3;
}

const sensor_msgs::PointField* findField(const sensor_msgs::PointCloud2& cloud,
                                         std::string_view name) {
  for (const auto& field : cloud.fields) {
    if (field.name == name) return &field;
  }
  return nullptr;
}

}  // namespace

core::Stamp toStamp(const ros::Time& time) { return static_cast<core::Stamp>(time.toNSec()); }

ros::Time toRosTime(core::Stamp stamp) {
  ros::Time time;
  time.fromNSec(static_cast<std::uint64_t>(stamp < 0 ? 0 : stamp));
  return time;
}

std::optional<core::Pose3> toPose(const geometry_msgs::Pose& pose) {
  const auto& p = pose.position;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) ||
      !isUnitQuaternion(pose.orientation)) {
    return std::nullopt;
  }
  Eigen::Isometry3d out;
  tf2::fromMsg(pose, out);
  out.linear() = Eigen::Quaterniond(out.linear()).normalized().toRotationMatrix();
  return out;
}

std::optional<core::Pose3> toPose(const geometry_msgs::Transform& transform) {
  geometry_msgs::Pose pose;
  pose.position.x = transform.translation.x;
  pose.position.y = transform.translation.y;
  pose.position.z = transform.translation.z;
  pose.orientation = transform.rotation;
  return toPose(pose);
}

geometry_msgs::Pose toPoseMsg(const core::Pose3& pose) { return tf2::toMsg(pose); }

std::optional<std::string> checkCloud(const sensor_msgs::PointCloud2& cloud, CloudFields* fields) {
  if (cloud.width == 0 || cloud.height == 0) return std::string("the cloud is empty");
  const std::uint64_t points = std::uint64_t{cloud.width} * cloud.height;
  if (cloud.point_step == 0) return std::string("point_step is 0");
  if (std::uint64_t{cloud.row_step} < std::uint64_t{cloud.width} * cloud.point_step) {
    return "row_step " + std::to_string(cloud.row_step) + " < width * point_step";
  }
  if (cloud.data.size() != std::uint64_t{cloud.row_step} * cloud.height) {
    return "data holds " + std::to_string(cloud.data.size()) + " bytes but row_step * height = " +
           std::to_string(std::uint64_t{cloud.row_step} * cloud.height) + " (" +
           std::to_string(points) + " points)";
  }
  for (const char* axis : {"x", "y", "z"}) {
    const sensor_msgs::PointField* field = findField(cloud, axis);
    if (!field) return std::string("field '") + axis + "' is missing";
    if (field->datatype != sensor_msgs::PointField::FLOAT32 || field->count != 1 ||
        field->offset + 4 > cloud.point_step) {
      return std::string("field '") + axis + "' is not one FLOAT32 inside point_step";
    }
  }
  if (fields) {
    fields->intensity = findField(cloud, "intensity") != nullptr;
    fields->ring = findField(cloud, "ring") != nullptr;
    fields->time = findField(cloud, "time") != nullptr || findField(cloud, "t") != nullptr;
  }
  return std::nullopt;
}

}  // namespace ccir_mapping::conversions
