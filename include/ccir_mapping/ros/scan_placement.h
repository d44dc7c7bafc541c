// Where a scan was taken: the sensor frame in the odometry frame at the scan's stamp, from tf
// (odom_source "tf": odom_frame -> sensor frame at the stamp), from odometry messages and the
// sensor mount on tf (odom_source "topic": base_frame in odom_frame, interpolated; the mount is
// static, so its latest transform is used) or from the scans themselves and the mount
// (odom_source "lidar": core::preprocess::LidarOdometry; odom_frame is base_frame at the first
// scan). Scans wait here, in arrival order, until what places them has arrived.
#pragma once

#include <optional>
#include <string>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/preprocess/lidar_odometry.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/preprocess/ordered_wait_queue.h"

namespace ccir_mapping::ros_params {
struct PreprocessorSettings;
}

namespace ccir_mapping {

class ScanPlacement {
 public:
  /// `odometry_topic` is named in the explanations of scans that wait for odometry.
  ScanPlacement(const ros_params::PreprocessorSettings& settings, std::string odometry_topic);

  /// The buffer a tf2_ros::TransformListener fills.
  tf2_ros::Buffer& tf() { return tf_; }

  /// Why odometry was refused: one of a few fixed problems, and what was wrong.
  struct Refusal {
    std::string problem;
    std::string detail;
  };
  /// Keeps the odometry for placing scans; otherwise says why it was refused (frames other than
  /// odom_frame -> base_frame, a pose not finite, a stamp not after the previous one).
  std::optional<Refusal> addOdometry(const nav_msgs::Odometry& msg);

  /// True once what places a scan of `sensor_frame` at `stamp` has arrived (tf at its stamp, or
  /// odometry at or after it and the mount); otherwise false, saying why in `why` when given.
  bool placeable(const std::string& sensor_frame, const ros::Time& stamp,
                 std::string* why = nullptr) const;

  /// The sensor frame in odom_frame at `stamp` from tf or odometry, or std::nullopt with the
  /// reason in `why`.
  std::optional<core::Pose3> sensorPose(const std::string& sensor_frame, const ros::Time& stamp,
                                        std::string* why) const;

  /// A scan placed (with its pose) or given up (without; `why` says why).
  struct Placement {
    sensor_msgs::PointCloud2::ConstPtr cloud;
    std::optional<core::Pose3> pose;
    std::string why;
    /// odom_source "lidar": odom_frame -> base_frame at the scan, for tf (the Preprocessor is
    /// the robot's odometry then), and what was odd about the registration.
    std::optional<geometry_msgs::TransformStamped> odometry_tf;
    std::optional<core::Notice> notice;
  };
  /// Scans that wait at most: two seconds of a VLP-16 at 10 Hz.
  static constexpr std::size_t kMaxWaitingScans = 20;
  /// Lets a scan wait until it can be placed (when kMaxWaitingScans already wait, the oldest is
  /// given up; one without a frame_id is given up at once) and returns release()'s.
  std::vector<Placement> wait(const sensor_msgs::PointCloud2::ConstPtr& cloud);
  /// The waiting scans that can be placed now, and those a later scan that could be placed
  /// overtook (given up: what places a scan arrives in time order), in arrival order; the rest
  /// wait on. Call it when odometry or tf arrived.
  std::vector<Placement> release();
  std::size_t waiting() const { return waiting_.size(); }

 private:
  Placement givenUp(const sensor_msgs::PointCloud2::ConstPtr& cloud, const char* context) const;
  /// base_frame -> sensor frame (static: the latest).
  std::optional<core::Pose3> mount(const std::string& sensor_frame, std::string* why) const;
  Placement placeByLidar(const sensor_msgs::PointCloud2::ConstPtr& cloud);

  bool from_tf_;
  std::string odom_frame_, base_frame_, odometry_topic_;
  double odom_tolerance_s_;
  core::preprocess::OdometryBuffer odometry_;
  std::unique_ptr<core::preprocess::LidarOdometry> lidar_;  // odom_source "lidar" only
  core::preprocess::LidarOdometry::Cloud lidar_scan_;       // conversion buffer
  tf2_ros::Buffer tf_;
  core::preprocess::OrderedWaitQueue<sensor_msgs::PointCloud2::ConstPtr> waiting_{kMaxWaitingScans};
};

}  // namespace ccir_mapping
