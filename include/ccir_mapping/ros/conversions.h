// Conversions between ROS messages and core types, and validation of incoming messages.
#pragma once

#include <optional>
#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/PeerRouting.h"
#include "ccir_mapping/ScanOffer.h"
#include "ccir_mapping/ScanReceipt.h"
#include "ccir_mapping/ScanRequest.h"
#include "ccir_mapping/SharedScan.h"
#include "ccir_mapping/core/common/lidar_scan.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/routing/routing_messages.h"

namespace ccir_mapping::conversions {

core::Stamp toStamp(const ros::Time& time);
ros::Time toRosTime(core::Stamp stamp);

/// nullopt when a coefficient is not finite or the quaternion is far from unit length.
std::optional<core::Pose3> toPose(const geometry_msgs::Pose& pose);
std::optional<core::Pose3> toPose(const geometry_msgs::Transform& transform);
geometry_msgs::Pose toPoseMsg(const core::Pose3& pose);
geometry_msgs::Transform toTransformMsg(const core::Pose3& pose);

/// The Velodyne ROS driver's layout: x y z intensity (FLOAT32), ring (UINT16), time (FLOAT32,
/// seconds after the stamp), packed in 22 bytes per point.
void toPointCloud2(const core::LidarScan& scan, const std::string& frame,
                   sensor_msgs::PointCloud2* cloud);

/// Which optional Velodyne fields a cloud has (x y z are required).
struct CloudFields {
  bool intensity = false;
  bool ring = false;
  bool time = false;
};

/// Checks a cloud before anything reads it: buffer size matches width, height and steps;
/// x y z are FLOAT32 inside point_step; optional fields are reported. Returns an error that
/// names the problem, or the fields found.
std::optional<std::string> checkCloud(const sensor_msgs::PointCloud2& cloud, CloudFields* fields);

/// Copies x y z and intensity (FLOAT32, UINT8 or UINT16; 0 when absent or of another type) of
/// every point, in the cloud's order and layout (width x height). Needs a cloud checkCloud
/// accepted.
void toPcl(const sensor_msgs::PointCloud2& cloud, pcl::PointCloud<pcl::PointXYZI>* out);

/// A keyframe's cloud as the Preprocessor publishes it (x y z intensity normal_x normal_y
/// normal_z, FLOAT32). Returns an error naming what is wrong, leaving `out` empty.
std::optional<std::string> toKeyframeCloud(const sensor_msgs::PointCloud2& cloud,
                                           pcl::PointCloud<pcl::PointXYZINormal>* out);

/// A keyframe in its wire form (SharedScan.msg, core/transport/scan_codec.h). Returns an error
/// naming what is wrong (the cloud is not a keyframe cloud, a value is not finite).
std::optional<std::string> toSharedScan(const Keyframe& keyframe, SharedScan* out);
/// A teammate's scan back as a keyframe (cloud x y z intensity normals, FLOAT32, as the
/// Preprocessor makes it). `max_points` bounds what a peer can make this robot allocate.
std::optional<std::string> toKeyframe(const SharedScan& scan, std::size_t max_points,
                                      Keyframe* out);

/// CCIR's protocol messages. A teammate's offer with a non-finite or non-unit pose is refused
/// (error), the rest cannot be malformed in their fields (the broker checks their content).
std::optional<std::string> toOffer(const ScanOffer& msg, core::routing::Offer* out);
ScanOffer toOfferMsg(const core::routing::Offer& offer, const std::string& map_frame);
core::routing::Request toRequest(const ScanRequest& msg);
ScanRequest toRequestMsg(const core::routing::Request& request);
core::routing::Receipt toReceipt(const ScanReceipt& msg);
ScanReceipt toReceiptMsg(const core::routing::Receipt& receipt);
core::routing::LinkState toLinkState(const LinkStats& msg);
PeerRouting toPeerRoutingMsg(const std::string& peer, const core::routing::PeerCounters& counters);

}  // namespace ccir_mapping::conversions
