// Conversions between ROS messages and core types, and validation of incoming messages.
#pragma once

#include <optional>
#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>
#include <topic_tools/shape_shifter.h>
#include <visualization_msgs/MarkerArray.h>
#include <boost/array.hpp>

#include "ccir_mapping/BrokerStats.h"
#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/KeyframeUncertainty.h"
#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/MapStats.h"
#include "ccir_mapping/ScanOffer.h"
#include "ccir_mapping/ScanReceipt.h"
#include "ccir_mapping/ScanRequest.h"
#include "ccir_mapping/SharedScan.h"
#include "ccir_mapping/TeamKeyframePoses.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/backend/team_graph.h"
#include "ccir_mapping/core/common/lidar_scan.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/place_recognition/matcher_stage.h"
#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/routing/routing_messages.h"
#include "ccir_mapping/core/routing/scan_encoding.h"
#include "ccir_mapping/core/transport/bridge_stage.h"

namespace ccir_mapping::conversions {

core::Stamp toStamp(const ros::Time& time);
ros::Time toRosTime(core::Stamp stamp);

/// nullopt when a coefficient is not finite or the quaternion is far from unit length.
std::optional<core::Pose3> toPose(const geometry_msgs::Pose& pose);
std::optional<core::Pose3> toPose(const geometry_msgs::Transform& transform);
geometry_msgs::Pose toPoseMsg(const core::Pose3& pose);
geometry_msgs::Transform toTransformMsg(const core::Pose3& pose);
/// `child`'s pose in `parent` at `stamp`, for tf.
geometry_msgs::TransformStamped toTransformStampedMsg(const ros::Time& stamp,
                                                      const std::string& parent,
                                                      const std::string& child,
                                                      const core::Pose3& pose);
/// Row-major 6 x 6 covariances of the messages.
core::Matrix6 toMatrix6(const boost::array<double, 36>& covariance);
boost::array<double, 36> toCovarianceMsg(const core::Matrix6& covariance);

/// The poses of a Path by stamp; non-finite ones are left out and counted in `skipped`.
std::vector<std::pair<core::Stamp, core::Pose3>> toStampedPoses(const nav_msgs::Path& path,
                                                                int* skipped = nullptr);
/// A Path of poses with their stamps, in `frame`, stamped with the last one.
nav_msgs::Path toPathMsg(const std::vector<core::Stamp>& stamps,
                         const std::vector<core::Pose3>& poses, const std::string& frame);

/// A loop closure's keyframes, relative pose, covariance, (when it is a valid pose: an unset
/// one has a zero quaternion) odom_pose_from and odom_pose_to, and match figures; false when the
/// relative pose is not finite (core::pose_graph::loopClosureProblem checks the rest).
bool toLoopClosure(const LoopClosure& msg, core::pose_graph::LoopClosureData* out);
/// The same fields of a LoopClosure message (its header is the finder's to set).
LoopClosure toLoopClosureMsg(const core::pose_graph::LoopClosureData& loop);
/// A team transform estimate of `estimate.peer`'s map frame in `map_frame`.
TeamTransform toTeamTransformMsg(const core::backend::TeamEstimate& estimate,
                                 const std::string& map_frame, const ros::Time& stamp);
/// The teammate's map frame in this robot's, or nullopt unless the message is valid and its
/// transform finite.
std::optional<core::Pose3> toTeamFrame(const TeamTransform& msg);

/// A teammate's keyframes as the team graph placed them, in `map_frame`.
TeamKeyframePoses toTeamKeyframePosesMsg(const core::backend::PeerKeyframes& keyframes,
                                         const std::string& map_frame, const ros::Time& stamp);
/// (keyframe, pose) pairs, or nullopt when ids and poses differ in length or a pose is not
/// finite (with a unit quaternion).
std::optional<std::vector<std::pair<core::KeyframeId, core::Pose3>>> toKeyframePoses(
    const TeamKeyframePoses& msg);

/// Pose uncertainty u_k of `robot`'s keyframes (same length).
KeyframeUncertainty toKeyframeUncertaintyMsg(const std::string& robot,
                                             const std_msgs::Header& header,
                                             const std::vector<core::KeyframeId>& ids,
                                             const std::vector<double>& variances_m2);
/// (keyframe, variance) pairs, or nullopt when ids and variances differ in length.
std::optional<std::vector<std::pair<core::KeyframeId, double>>> toVariances(
    const KeyframeUncertainty& msg);

/// A keyframe's word set, in the header of the keyframe it was made of, and back.
KeyframeFeatures toKeyframeFeaturesMsg(const std_msgs::Header& header,
                                       const core::place_recognition::KeyframeWords& words);
core::place_recognition::KeyframeWords toKeyframeWords(const KeyframeFeatures& msg);

/// c_k of `robot`'s keyframes with one teammate keyframe, and back (nullopt when ids and counts
/// differ in length).
Correspondences toCorrespondencesMsg(const std::string& robot,
                                     const core::place_recognition::KeyframeCorrespondences& c,
                                     const ros::Time& stamp);
std::optional<core::place_recognition::KeyframeCorrespondences> toKeyframeCorrespondences(
    const Correspondences& msg);

/// What a Backend snapshot puts on tf at `stamp`: odom_frame in map_frame, and each teammate's
/// map frame ("<peer>/map") whose transform is found.
std::vector<geometry_msgs::TransformStamped> toTfMsgs(
    const core::backend::BackendSnapshot& snapshot, const std::string& map_frame,
    const std::string& odom_frame, const ros::Time& stamp);

/// Loop closures as lines between their keyframes, one LINE_LIST each: kept intra-robot ones
/// green ("loops kept"), rejected red ("loops rejected"), inter-robot blue ("inter-robot
/// loops"); an empty list is a DELETE (rviz would keep drawing the last lines).
visualization_msgs::MarkerArray toLoopMarkersMsg(const std::vector<core::backend::LoopLine>& lines,
                                                 const std::string& map_frame,
                                                 const ros::Time& stamp);

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

/// The optional fields of the Velodyne driver's layout a cloud lacks ("intensity ring time"),
/// or "" when it has them all.
std::string missingVelodyneFields(const CloudFields& fields);

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

/// A keyframe as the Preprocessor publishes it: `cloud` of the scan with `header` (the sensor
/// frame at its stamp), taken by `robot` at `odom_pose` in `odom_frame`, as the selector decided.
Keyframe toKeyframeMsg(const std_msgs::Header& header, const std::string& robot,
                       const std::string& odom_frame, const core::Pose3& odom_pose,
                       const core::preprocess::KeyframeSelector::Decision& decision,
                       const pcl::PointCloud<pcl::PointXYZINormal>& cloud);

/// A keyframe's points (x y z, sensor frame) and odometry pose, what the map needs. Returns an
/// error when its cloud is malformed or empty or its pose not finite.
std::optional<std::string> toScanPoints(const Keyframe& keyframe,
                                        pcl::PointCloud<pcl::PointXYZ>* points,
                                        core::Pose3* odom_pose);

/// An own keyframe in its wire form (core/routing/scan_encoding.h: `broker`'s scan_encoding),
/// and when asked its points (x y z). Returns an error naming what is wrong (the cloud is not a
/// keyframe cloud, a value is not finite).
std::optional<std::string> toWireScan(const Keyframe& keyframe,
                                      const core::routing::BrokerParams& broker,
                                      core::routing::WireScan* out,
                                      pcl::PointCloud<pcl::PointXYZ>* xyz = nullptr);
/// That wire form as the message the Broker sends (the points moved, not copied).
SharedScan toSharedScanMsg(core::routing::WireScan&& scan, const std::string& sensor_frame,
                           const std::string& odom_frame);
/// A teammate's scan back as a keyframe (cloud x y z intensity normals, FLOAT32, as the
/// Preprocessor makes it; core::routing::decodeWireScan bounds what a peer can make this robot
/// allocate).
std::optional<std::string> toKeyframe(const SharedScan& scan, Keyframe* out);

/// CCIR's protocol messages. A teammate's offer with a non-finite or non-unit pose is refused
/// (error; its provider and requester are set all the same), the rest cannot be malformed in
/// their fields (the broker checks their content).
std::optional<std::string> toOffer(const ScanOffer& msg, core::routing::Offer* out);
ScanOffer toOfferMsg(const core::routing::Offer& offer, const std::string& map_frame);
/// The serialised size of a control message's ROS message (its offer in `map_frame`).
std::size_t serializedSize(const core::routing::ControlMessage& message,
                           const std::string& map_frame);
core::routing::Request toRequest(const ScanRequest& msg);
ScanRequest toRequestMsg(const core::routing::Request& request);
core::routing::Receipt toReceipt(const ScanReceipt& msg);
ScanReceipt toReceiptMsg(const core::routing::Receipt& receipt);
core::routing::LinkState toLinkState(const LinkStats& msg);
/// What the Bridge tells teammates of an outbox message's topic: its inbox name, the type, md5
/// and definition the publisher announced, whether it latches (its connection header says so),
/// and how it travels.
core::transport::TopicInfo toTopicInfo(const topic_tools::ShapeShifter& msg,
                                       const core::transport::ForwardedTopic& forwarded,
                                       const ros::M_string* connection_header);
/// A message's serialised bytes.
std::vector<std::uint8_t> toBytes(const topic_tools::ShapeShifter& msg);
/// A teammate's message as its topic described it, or null when the description cannot be one
/// (a type without a package, an md5 not of 32 characters), with why in `error`.
topic_tools::ShapeShifter::ConstPtr toShapeShifter(const core::transport::InboxMessage& message,
                                                   std::string* error);

/// One bridge link's report at `now`, with the budgets of `params` and the send rate measured
/// since the previous report; drop reasons that never happened are left out.
LinkStats toLinkStatsMsg(const core::transport::LinkReport& report, const std::string& robot,
                         const core::transport::BridgeParams& params, const ros::Time& now,
                         double send_rate_bytes_per_s);
/// A robot's map statistics, with the map's resolution and entropy box from its parameters.
MapStats toMapStatsMsg(const core::information::MapperStage::Stats& stats,
                       const core::information::MapperParams& params, const std::string& robot,
                       const std_msgs::Header& header);

/// The totals, with the scan bytes summed over the teammates, and each teammate's counters.
BrokerStats toBrokerStatsMsg(const core::routing::BrokerReport& report, const ros::Time& stamp);

}  // namespace ccir_mapping::conversions
