#include "ccir_mapping/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string_view>

#include <pcl/common/io.h>
#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/PointField.h>
#include <tf2_eigen/tf2_eigen.h>

#include "ccir_mapping/core/routing/scan_encoding.h"
#include "ccir_mapping/ros/topic_routes.h"

namespace ccir_mapping::conversions {

namespace {

/// A teammate's map frame, as its own robot names it.
std::string peerMapFrame(const std::string& peer) { return peer + "/map"; }

/// A message's parallel lists of keyframe ids and values as pairs; nullopt when their lengths
/// differ.
template <class T, class Values>
std::optional<std::vector<std::pair<core::KeyframeId, T>>> perKeyframe(
    const std::vector<std::uint64_t>& ids, const Values& values) {
  if (ids.size() != values.size()) return std::nullopt;
  std::vector<std::pair<core::KeyframeId, T>> pairs;
  for (std::size_t i = 0; i < ids.size(); ++i)
    pairs.emplace_back(ids[i], static_cast<T>(values[i]));
  return pairs;
}

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

/// Bytes of one value of a PointField datatype; 1 for an unknown one (its offset must still
/// lie inside the point).
std::uint64_t valueBytes(std::uint8_t datatype) {
  using F = sensor_msgs::PointField;
  switch (datatype) {
    case F::INT16:
    case F::UINT16:
      return 2;
    case F::INT32:
    case F::UINT32:
    case F::FLOAT32:
      return 4;
    case F::FLOAT64:
      return 8;
    default:
      return 1;
  }
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

geometry_msgs::Transform toTransformMsg(const core::Pose3& pose) {
  return tf2::eigenToTransform(pose).transform;
}

geometry_msgs::TransformStamped toTransformStampedMsg(const ros::Time& stamp,
                                                      const std::string& parent,
                                                      const std::string& child,
                                                      const core::Pose3& pose) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  msg.transform = toTransformMsg(pose);
  return msg;
}

core::Matrix6 toMatrix6(const boost::array<double, 36>& covariance) {
  return Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(covariance.data());
}

boost::array<double, 36> toCovarianceMsg(const core::Matrix6& covariance) {
  boost::array<double, 36> out;
  Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(out.data()) = covariance;
  return out;
}

std::vector<std::pair<core::Stamp, core::Pose3>> toStampedPoses(const nav_msgs::Path& path,
                                                                int* skipped) {
  std::vector<std::pair<core::Stamp, core::Pose3>> poses;
  for (const auto& p : path.poses) {
    if (const auto pose = toPose(p.pose)) {
      poses.emplace_back(toStamp(p.header.stamp), *pose);
    } else if (skipped) {
      ++*skipped;
    }
  }
  return poses;
}

nav_msgs::Path toPathMsg(const std::vector<core::Stamp>& stamps,
                         const std::vector<core::Pose3>& poses, const std::string& frame) {
  nav_msgs::Path path;
  path.header.frame_id = frame;
  if (!stamps.empty()) path.header.stamp = toRosTime(stamps.back());
  for (std::size_t i = 0; i < std::min(stamps.size(), poses.size()); ++i) {
    geometry_msgs::PoseStamped pose;
    pose.header.frame_id = frame;
    pose.header.stamp = toRosTime(stamps[i]);
    pose.pose = toPoseMsg(poses[i]);
    path.poses.push_back(pose);
  }
  return path;
}

bool toLoopClosure(const LoopClosure& msg, core::pose_graph::LoopClosureData* out) {
  const auto relative = toPose(msg.relative_pose);
  if (!relative) return false;
  out->robot_from = msg.robot_from;
  out->keyframe_from = msg.keyframe_from;
  out->robot_to = msg.robot_to;
  out->keyframe_to = msg.keyframe_to;
  out->relative = *relative;
  out->covariance = toMatrix6(msg.covariance);
  out->odom_pose_from = toPose(msg.odom_pose_from);
  out->odom_pose_to = toPose(msg.odom_pose_to);
  out->match_score = msg.match_score;
  out->new_place_probability = msg.new_place_probability;
  out->fitness_m2 = msg.fitness_m2;
  out->inliers = static_cast<int>(msg.inliers);
  out->method = msg.method;
  return true;
}

LoopClosure toLoopClosureMsg(const core::pose_graph::LoopClosureData& loop) {
  LoopClosure msg;
  msg.robot_from = loop.robot_from;
  msg.keyframe_from = loop.keyframe_from;
  msg.robot_to = loop.robot_to;
  msg.keyframe_to = loop.keyframe_to;
  msg.relative_pose = toPoseMsg(loop.relative);
  msg.covariance = toCovarianceMsg(loop.covariance);
  if (loop.odom_pose_from) msg.odom_pose_from = toPoseMsg(*loop.odom_pose_from);
  if (loop.odom_pose_to) msg.odom_pose_to = toPoseMsg(*loop.odom_pose_to);
  msg.match_score = loop.match_score;
  msg.new_place_probability = loop.new_place_probability;
  msg.fitness_m2 = loop.fitness_m2;
  msg.inliers = static_cast<std::uint32_t>(std::max(0, loop.inliers));
  msg.method = loop.method;
  return msg;
}

visualization_msgs::MarkerArray toLoopMarkersMsg(const std::vector<core::backend::LoopLine>& lines,
                                                 const std::string& map_frame,
                                                 const ros::Time& stamp) {
  visualization_msgs::MarkerArray markers;
  const char* names[] = {"loops kept", "loops rejected", "inter-robot loops"};
  const float colours[][3] = {{0.1F, 0.8F, 0.1F}, {0.9F, 0.1F, 0.1F}, {0.2F, 0.4F, 1.0F}};
  for (int kind = 0; kind < 3; ++kind) {
    visualization_msgs::Marker m;
    m.header.frame_id = map_frame;
    m.header.stamp = stamp;
    m.ns = names[kind];
    m.type = visualization_msgs::Marker::LINE_LIST;
    m.pose.orientation.w = 1.0;
    m.scale.x = 0.1;
    m.color.r = colours[kind][0];
    m.color.g = colours[kind][1];
    m.color.b = colours[kind][2];
    m.color.a = 1.0F;
    for (const auto& line : lines) {
      // Rejected ones red whichever robots they join.
      if ((!line.accepted ? 1 : (line.inter_robot ? 2 : 0)) != kind) continue;
      m.points.push_back(tf2::toMsg(line.from));
      m.points.push_back(tf2::toMsg(line.to));
    }
    m.action =
        m.points.empty() ? visualization_msgs::Marker::DELETE : visualization_msgs::Marker::ADD;
    markers.markers.push_back(m);
  }
  return markers;
}

TeamTransform toTeamTransformMsg(const core::backend::TeamEstimate& estimate,
                                 const std::string& map_frame, const ros::Time& stamp) {
  const auto& a = estimate.alignment;
  TeamTransform msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = map_frame;
  msg.peer = estimate.peer;
  msg.child_frame_id = peerMapFrame(estimate.peer);
  msg.valid = a.found;
  msg.transform = toTransformMsg(a.transform);
  msg.covariance = toCovarianceMsg(a.covariance);
  msg.inliers = static_cast<std::uint32_t>(a.inlier_count);
  msg.candidates = static_cast<std::uint32_t>(estimate.candidates);
  msg.margin = a.runner_up_inliers > 0 ? double(a.inlier_count) / a.runner_up_inliers
                                       : double(a.inlier_count);
  return msg;
}

std::vector<geometry_msgs::TransformStamped> toTfMsgs(
    const core::backend::BackendSnapshot& snapshot, const std::string& map_frame,
    const std::string& odom_frame, const ros::Time& stamp) {
  std::vector<geometry_msgs::TransformStamped> transforms = {
      toTransformStampedMsg(stamp, map_frame, odom_frame, snapshot.mapFromOdom())};
  for (const auto& estimate : snapshot.team) {
    if (!estimate.alignment.found) continue;
    transforms.push_back(toTransformStampedMsg(stamp, map_frame, peerMapFrame(estimate.peer),
                                               estimate.alignment.transform));
  }
  return transforms;
}

std::optional<core::Pose3> toTeamFrame(const TeamTransform& msg) {
  return msg.valid ? toPose(msg.transform) : std::nullopt;
}

TeamKeyframePoses toTeamKeyframePosesMsg(const core::backend::PeerKeyframes& keyframes,
                                         const std::string& map_frame, const ros::Time& stamp) {
  TeamKeyframePoses msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = map_frame;
  msg.robot = keyframes.robot;
  msg.keyframe_ids.assign(keyframes.ids.begin(), keyframes.ids.end());
  for (const auto& pose : keyframes.poses) msg.poses.push_back(toPoseMsg(pose));
  return msg;
}

std::optional<std::vector<std::pair<core::KeyframeId, core::Pose3>>> toKeyframePoses(
    const TeamKeyframePoses& msg) {
  if (msg.keyframe_ids.size() != msg.poses.size()) return std::nullopt;
  std::vector<std::pair<core::KeyframeId, core::Pose3>> pairs;
  for (std::size_t i = 0; i < msg.poses.size(); ++i) {
    const auto pose = toPose(msg.poses[i]);
    if (!pose) return std::nullopt;
    pairs.emplace_back(msg.keyframe_ids[i], *pose);
  }
  return pairs;
}

KeyframeUncertainty toKeyframeUncertaintyMsg(const std::string& robot,
                                             const std_msgs::Header& header,
                                             const std::vector<core::KeyframeId>& ids,
                                             const std::vector<double>& variances_m2) {
  KeyframeUncertainty msg;
  msg.header = header;
  msg.robot = robot;
  msg.keyframe_ids.assign(ids.begin(), ids.end());
  msg.position_variance_m2 = variances_m2;
  return msg;
}

std::optional<std::vector<std::pair<core::KeyframeId, double>>> toVariances(
    const KeyframeUncertainty& msg) {
  return perKeyframe<double>(msg.keyframe_ids, msg.position_variance_m2);
}

KeyframeFeatures toKeyframeFeaturesMsg(const std_msgs::Header& header,
                                       const core::place_recognition::KeyframeWords& words) {
  KeyframeFeatures msg;
  msg.header = header;
  msg.robot = words.robot;
  msg.keyframe_id = words.id;
  msg.vocabulary_hash = words.vocabulary_hash;
  msg.words = words.words;
  msg.descriptor_count = words.descriptor_count;
  return msg;
}

core::place_recognition::KeyframeWords toKeyframeWords(const KeyframeFeatures& msg) {
  return {msg.robot,           msg.keyframe_id, toStamp(msg.header.stamp),
          msg.vocabulary_hash, msg.words,       msg.descriptor_count};
}

Correspondences toCorrespondencesMsg(const std::string& robot,
                                     const core::place_recognition::KeyframeCorrespondences& c,
                                     const ros::Time& stamp) {
  Correspondences msg;
  msg.header.stamp = stamp;
  msg.robot = robot;
  msg.peer = c.peer;
  msg.peer_keyframe_id = c.peer_keyframe;
  for (const auto& [keyframe, count] : c.counts) {
    msg.keyframe_ids.push_back(keyframe);
    msg.counts.push_back(static_cast<std::uint32_t>(count));
  }
  return msg;
}

std::optional<core::place_recognition::KeyframeCorrespondences> toKeyframeCorrespondences(
    const Correspondences& msg) {
  auto counts = perKeyframe<int>(msg.keyframe_ids, msg.counts);
  if (!counts) return std::nullopt;
  return core::place_recognition::KeyframeCorrespondences{msg.peer, msg.peer_keyframe_id,
                                                          std::move(*counts)};
}

void toPointCloud2(const core::LidarScan& scan, const std::string& frame,
                   sensor_msgs::PointCloud2* cloud) {
  using sensor_msgs::PointField;
  constexpr std::uint32_t kPointStep = 22;
  cloud->header.stamp = toRosTime(scan.stamp);
  cloud->header.frame_id = frame;
  struct FieldSpec {
    const char* name;
    std::uint32_t offset;
    std::uint8_t datatype;
  };
  static constexpr FieldSpec kLayout[] = {
      {"x", 0, PointField::FLOAT32},    {"y", 4, PointField::FLOAT32},
      {"z", 8, PointField::FLOAT32},    {"intensity", 12, PointField::FLOAT32},
      {"ring", 16, PointField::UINT16}, {"time", 18, PointField::FLOAT32}};
  cloud->fields.clear();
  for (const auto& spec : kLayout) {
    PointField field;
    field.name = spec.name;
    field.offset = spec.offset;
    field.datatype = spec.datatype;
    field.count = 1;
    cloud->fields.push_back(field);
  }
  const auto count = static_cast<std::uint32_t>(scan.points.size());
  if (scan.organized && scan.columns > 0) {
    cloud->height = static_cast<std::uint32_t>(scan.rings);
    cloud->width = static_cast<std::uint32_t>(scan.columns);
  } else {
    cloud->height = 1;
    cloud->width = count;
  }
  cloud->is_bigendian = false;
  cloud->point_step = kPointStep;
  cloud->row_step = kPointStep * cloud->width;
  cloud->is_dense = !scan.organized;
  cloud->data.resize(std::size_t{kPointStep} * count);
  static_assert(offsetof(core::LidarPoint, intensity) == 12);
  std::uint8_t* out = cloud->data.data();
  for (const auto& p : scan.points) {
    std::memcpy(out, &p.x, 16);  // x y z intensity are contiguous floats
    std::memcpy(out + 16, &p.ring, 2);
    std::memcpy(out + 18, &p.time, 4);
    out += kPointStep;
  }
}

std::string missingVelodyneFields(const CloudFields& fields) {
  std::string missing;
  for (const auto& [present, name] :
       {std::pair{fields.intensity, "intensity"}, std::pair{fields.ring, "ring"},
        std::pair{fields.time, "time"}}) {
    if (!present) missing += missing.empty() ? name : std::string(" ") + name;
  }
  return missing;
}

std::optional<std::string> checkCloud(const sensor_msgs::PointCloud2& cloud, CloudFields* fields) {
  if (cloud.width == 0 || cloud.height == 0) return std::string("the cloud is empty");
  const std::uint64_t points = std::uint64_t{cloud.width} * cloud.height;
  if (cloud.point_step == 0) return std::string("point_step is 0");
  if (cloud.is_bigendian) return std::string("big-endian data is not supported");
  if (std::uint64_t{cloud.row_step} < std::uint64_t{cloud.width} * cloud.point_step) {
    return "row_step " + std::to_string(cloud.row_step) + " < width * point_step";
  }
  if (cloud.data.size() != std::uint64_t{cloud.row_step} * cloud.height) {
    return "data holds " + std::to_string(cloud.data.size()) + " bytes but row_step * height = " +
           std::to_string(std::uint64_t{cloud.row_step} * cloud.height) + " (" +
           std::to_string(points) + " points)";
  }
  // Every field inside the point (in 64 bits: an offset near 2^32 must not wrap around), so
  // that neither these conversions nor PCL's, which map fields by name, read beyond it.
  for (const auto& field : cloud.fields) {
    const std::uint64_t end = std::uint64_t{field.offset} +
                              std::max<std::uint64_t>(field.count, 1) * valueBytes(field.datatype);
    if (end > cloud.point_step) {
      return "field '" + field.name + "' ends at byte " + std::to_string(end) +
             ", beyond point_step " + std::to_string(cloud.point_step);
    }
  }
  for (const char* axis : {"x", "y", "z"}) {
    const sensor_msgs::PointField* field = findField(cloud, axis);
    if (!field) return std::string("field '") + axis + "' is missing";
    if (field->datatype != sensor_msgs::PointField::FLOAT32 || field->count != 1) {
      return std::string("field '") + axis + "' is not one FLOAT32";
    }
  }
  if (fields) {
    fields->intensity = findField(cloud, "intensity") != nullptr;
    fields->ring = findField(cloud, "ring") != nullptr;
    fields->time = findField(cloud, "time") != nullptr || findField(cloud, "t") != nullptr;
  }
  return std::nullopt;
}

void toPcl(const sensor_msgs::PointCloud2& cloud, pcl::PointCloud<pcl::PointXYZI>* out) {
  const std::uint32_t x = findField(cloud, "x")->offset;
  const std::uint32_t y = findField(cloud, "y")->offset;
  const std::uint32_t z = findField(cloud, "z")->offset;
  const sensor_msgs::PointField* intensity = findField(cloud, "intensity");
  const std::uint8_t type = intensity ? intensity->datatype : 0;
  const std::uint32_t size = type == sensor_msgs::PointField::FLOAT32  ? 4
                             : type == sensor_msgs::PointField::UINT16 ? 2
                             : type == sensor_msgs::PointField::UINT8  ? 1
                                                                       : 0;
  const bool has_intensity = size > 0;  // inside the point: checkCloud
  out->resize(std::size_t{cloud.width} * cloud.height);
  out->width = cloud.width;
  out->height = cloud.height;
  out->is_dense = cloud.is_dense;
  std::size_t i = 0;
  for (std::uint32_t row = 0; row < cloud.height; ++row) {
    const std::uint8_t* point = cloud.data.data() + std::size_t{row} * cloud.row_step;
    for (std::uint32_t column = 0; column < cloud.width; ++column, ++i, point += cloud.point_step) {
      pcl::PointXYZI& p = (*out)[i];
      std::memcpy(&p.x, point + x, 4);
      std::memcpy(&p.y, point + y, 4);
      std::memcpy(&p.z, point + z, 4);
      p.intensity = 0.0F;
      if (!has_intensity) continue;
      if (size == 4) {
        std::memcpy(&p.intensity, point + intensity->offset, 4);
      } else if (size == 2) {
        std::uint16_t value;
        std::memcpy(&value, point + intensity->offset, 2);
        p.intensity = value;
      } else {
        p.intensity = point[intensity->offset];
      }
    }
  }
}

std::optional<std::string> toKeyframeCloud(const sensor_msgs::PointCloud2& cloud,
                                           pcl::PointCloud<pcl::PointXYZINormal>* out) {
  out->clear();
  if (auto error = checkCloud(cloud, nullptr)) return error;
  for (const char* name : {"intensity", "normal_x", "normal_y", "normal_z"}) {
    const sensor_msgs::PointField* field = findField(cloud, name);
    if (!field || field->datatype != sensor_msgs::PointField::FLOAT32 || field->count != 1) {
      return std::string("field '") + name + "' is missing or not one FLOAT32";
    }
  }
  pcl::fromROSMsg(cloud, *out);  // fields and buffer size checked above
  return std::nullopt;
}

Keyframe toKeyframeMsg(const std_msgs::Header& header, const std::string& robot,
                       const std::string& odom_frame, const core::Pose3& odom_pose,
                       const core::preprocess::KeyframeSelector::Decision& decision,
                       const pcl::PointCloud<pcl::PointXYZINormal>& cloud) {
  Keyframe msg;
  msg.header = header;
  msg.robot = robot;
  msg.id = decision.id;
  msg.odom_frame = odom_frame;
  msg.odom_pose = toPoseMsg(odom_pose);
  msg.travelled_m = static_cast<float>(decision.travelled_m);
  msg.rotated_rad = static_cast<float>(decision.rotated_rad);
  pcl::toROSMsg(cloud, msg.cloud);
  msg.cloud.header = header;
  return msg;
}

std::optional<std::string> toScanPoints(const Keyframe& keyframe,
                                        pcl::PointCloud<pcl::PointXYZ>* points,
                                        core::Pose3* odom_pose) {
  if (auto error = checkCloud(keyframe.cloud, nullptr)) return error;
  const auto pose = toPose(keyframe.odom_pose);
  if (!pose) return "odom_pose is not finite";
  pcl::fromROSMsg(keyframe.cloud, *points);
  *odom_pose = *pose;
  return std::nullopt;
}

std::optional<std::string> toWireScan(const Keyframe& keyframe,
                                      const core::routing::BrokerParams& broker,
                                      core::routing::WireScan* out,
                                      pcl::PointCloud<pcl::PointXYZ>* xyz) {
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  if (auto error = toKeyframeCloud(keyframe.cloud, &cloud)) return error;
  const auto pose = toPose(keyframe.odom_pose);
  if (!pose) return "odom_pose is not finite";
  out->robot = keyframe.robot;
  out->id = keyframe.id;
  out->stamp = toStamp(keyframe.header.stamp);
  out->odom_pose = *pose;
  out->travelled_m = keyframe.travelled_m;
  out->rotated_rad = keyframe.rotated_rad;
  std::string error;
  if (!core::routing::encodeWireScan(cloud, broker, out, &error)) return error;
  if (xyz) pcl::copyPointCloud(cloud, *xyz);
  return std::nullopt;
}

SharedScan toSharedScanMsg(core::routing::WireScan&& scan, const std::string& sensor_frame,
                           const std::string& odom_frame) {
  SharedScan msg;
  msg.header.stamp = toRosTime(scan.stamp);
  msg.header.frame_id = sensor_frame;
  msg.robot = std::move(scan.robot);
  msg.id = scan.id;
  msg.odom_frame = odom_frame;
  msg.odom_pose = toPoseMsg(scan.odom_pose);
  msg.travelled_m = scan.travelled_m;
  msg.rotated_rad = scan.rotated_rad;
  msg.encoding = scan.encoding == core::routing::ScanEncoding::kGmm ? SharedScan::ENCODING_GMM
                                                                    : SharedScan::ENCODING_CLOUD;
  msg.point_count = scan.point_count;
  msg.points = std::move(scan.points);
  return msg;
}

std::optional<std::string> toKeyframe(const SharedScan& scan, Keyframe* out) {
  if (scan.encoding != SharedScan::ENCODING_CLOUD && scan.encoding != SharedScan::ENCODING_GMM) {
    return "encoding " + std::to_string(scan.encoding) + " is unknown";
  }
  const auto encoding = scan.encoding == SharedScan::ENCODING_GMM
                            ? core::routing::ScanEncoding::kGmm
                            : core::routing::ScanEncoding::kCloud;
  std::string error;
  const auto cloud =
      core::routing::decodeWireScan(scan.points, encoding, scan.point_count, scan.id, &error);
  if (!cloud) return "points: " + error;
  if (!toPose(scan.odom_pose)) return std::string("odom_pose is not finite");
  pcl::toROSMsg(*cloud, out->cloud);
  out->header = scan.header;
  out->cloud.header = scan.header;
  out->robot = scan.robot;
  out->id = scan.id;
  out->odom_frame = scan.odom_frame;
  out->odom_pose = scan.odom_pose;
  out->travelled_m = scan.travelled_m;
  out->rotated_rad = scan.rotated_rad;
  out->drawn_from_mixture = encoding == core::routing::ScanEncoding::kGmm;
  return std::nullopt;
}

std::optional<std::string> toOffer(const ScanOffer& msg, core::routing::Offer* out) {
  out->provider = msg.provider;
  out->requester = msg.requester;
  out->sequence = msg.sequence;
  out->scans.clear();
  for (const auto& scan : msg.scans) {
    const auto pose = toPose(scan.pose);
    if (!pose)
      return "the pose of offered keyframe " + std::to_string(scan.keyframe_id) + " is not valid";
    core::routing::OfferEntry entry;
    entry.id = scan.keyframe_id;
    entry.pose = *pose;
    entry.correspondences = static_cast<int>(scan.correspondences);
    entry.size_bytes = scan.size_bytes;
    entry.utility = scan.utility;
    out->scans.push_back(entry);
  }
  return std::nullopt;
}

ScanOffer toOfferMsg(const core::routing::Offer& offer, const std::string& map_frame) {
  ScanOffer msg;
  msg.provider = offer.provider;
  msg.requester = offer.requester;
  msg.sequence = offer.sequence;
  msg.map_frame = map_frame;
  for (const auto& entry : offer.scans) {
    OfferedScan scan;
    scan.keyframe_id = entry.id;
    scan.pose = toPoseMsg(entry.pose);
    scan.correspondences = static_cast<std::uint32_t>(std::max(0, entry.correspondences));
    scan.size_bytes = static_cast<std::uint32_t>(entry.size_bytes);
    scan.utility = entry.utility;
    msg.scans.push_back(scan);
  }
  return msg;
}

std::size_t serializedSize(const core::routing::ControlMessage& message,
                           const std::string& map_frame) {
  using ros::serialization::serializationLength;
  if (const auto* offer = std::get_if<core::routing::Offer>(&message)) {
    return serializationLength(toOfferMsg(*offer, map_frame));
  }
  if (const auto* request = std::get_if<core::routing::Request>(&message)) {
    return serializationLength(toRequestMsg(*request));
  }
  return serializationLength(toReceiptMsg(std::get<core::routing::Receipt>(message)));
}

core::routing::Request toRequest(const ScanRequest& msg) {
  return {msg.requester, msg.provider, msg.offer_sequence,
          std::vector<core::KeyframeId>(msg.keyframe_ids.begin(), msg.keyframe_ids.end())};
}

ScanRequest toRequestMsg(const core::routing::Request& request) {
  ScanRequest msg;
  msg.requester = request.requester;
  msg.provider = request.provider;
  msg.offer_sequence = request.offer_sequence;
  msg.keyframe_ids.assign(request.ids.begin(), request.ids.end());
  return msg;
}

core::routing::Receipt toReceipt(const ScanReceipt& msg) {
  return {msg.receiver, msg.provider,
          std::vector<core::KeyframeId>(msg.keyframe_ids.begin(), msg.keyframe_ids.end())};
}

ScanReceipt toReceiptMsg(const core::routing::Receipt& receipt) {
  ScanReceipt msg;
  msg.receiver = receipt.receiver;
  msg.provider = receipt.provider;
  msg.keyframe_ids.assign(receipt.ids.begin(), receipt.ids.end());
  return msg;
}

core::routing::LinkState toLinkState(const LinkStats& msg) {
  core::routing::LinkState state;
  state.connected = msg.connected != 0;
  state.budget_bytes_per_s = msg.budget_bytes_per_s;
  state.total_budget_bytes_per_s = msg.total_budget_bytes_per_s;
  state.queued_control_bytes = static_cast<std::size_t>(msg.queued_control_bytes);
  state.queued_bulk_bytes = static_cast<std::size_t>(msg.queued_bulk_bytes);
  state.available_tokens_bytes = msg.available_tokens_bytes;
  return state;
}

core::transport::TopicInfo toTopicInfo(const topic_tools::ShapeShifter& msg,
                                       const core::transport::ForwardedTopic& forwarded,
                                       const ros::M_string* connection_header) {
  bool latched = false;
  if (connection_header) {
    const auto latching = connection_header->find("latching");
    latched = latching != connection_header->end() && latching->second == "1";
  }
  core::transport::TopicInfo topic;
  topic.name = topics::inboxOf(forwarded.topic);
  topic.type = msg.getDataType();
  topic.md5 = msg.getMD5Sum();
  topic.definition = msg.getMessageDefinition();
  topic.latched = latched;
  topic.reliable = forwarded.reliable;
  topic.compressed = forwarded.compress;
  topic.policy = forwarded.policy;
  return topic;
}

std::vector<std::uint8_t> toBytes(const topic_tools::ShapeShifter& msg) {
  std::vector<std::uint8_t> bytes(msg.size());
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  msg.write(stream);
  return bytes;
}

topic_tools::ShapeShifter::ConstPtr toShapeShifter(const core::transport::InboxMessage& message,
                                                   std::string* error) {
  const core::transport::TopicInfo& topic = message.topic;
  if (topic.type.find('/') == std::string::npos || topic.md5.size() != 32) {
    *error = "type '" + topic.type + "', md5 '" + topic.md5 + "'";
    return nullptr;
  }
  auto msg = boost::make_shared<topic_tools::ShapeShifter>();
  msg->morph(topic.md5, topic.type, topic.definition, topic.latched ? "1" : "0");
  // IStream takes a mutable pointer but only reads; ShapeShifter::read copies the bytes.
  ros::serialization::IStream stream(const_cast<std::uint8_t*>(message.bytes.data()),
                                     static_cast<std::uint32_t>(message.bytes.size()));
  msg->read(stream);
  return msg;
}

LinkStats toLinkStatsMsg(const core::transport::LinkReport& report, const std::string& robot,
                         const core::transport::BridgeParams& params, const ros::Time& now,
                         double send_rate_bytes_per_s) {
  LinkStats msg;
  msg.header.stamp = now;
  msg.robot = robot;
  msg.peer = report.peer;
  msg.connected = report.connected;
  msg.address = report.address;
  msg.bytes_sent = report.sent.bytes_sent;
  msg.bytes_received = report.received.bytes_received;
  msg.messages_sent = report.sent.messages_sent;
  msg.messages_received = report.received.messages_received;
  msg.send_rate_bytes_per_s = send_rate_bytes_per_s;
  msg.budget_bytes_per_s = params.budget_bytes_per_s;
  msg.total_budget_bytes_per_s = params.total_budget_bytes_per_s;
  msg.queued_control = static_cast<std::uint32_t>(report.queued_control);
  msg.queued_bulk = static_cast<std::uint32_t>(report.queued_bulk);
  msg.queued_control_bytes = report.queued_control_bytes;
  msg.queued_bulk_bytes = report.queued_bulk_bytes;
  msg.available_tokens_bytes = report.available_tokens_bytes;
  msg.peer_restarts = static_cast<std::uint32_t>(report.received.peer_restarts);
  for (const auto& [reason, n] : report.drops) {
    if (n == 0) continue;
    msg.drop_reasons.push_back(reason);
    msg.drop_counts.push_back(n);
  }
  if (report.silent_s >= 0 && now.toSec() >= report.silent_s) {
    msg.last_seen = now - ros::Duration(report.silent_s);
  }
  return msg;
}

namespace {

PeerRouting toPeerRoutingMsg(const std::string& peer, const core::routing::PeerCounters& c) {
  PeerRouting msg;
  msg.peer = peer;
  msg.offers_sent = c.offers_sent;
  msg.scans_offered = c.scans_offered;
  msg.offers_received = c.offers_received;
  msg.scans_in_offers_received = c.scans_in_offers_received;
  msg.requests_sent = c.requests_sent;
  msg.scans_requested = c.scans_requested;
  msg.requests_received = c.requests_received;
  msg.scans_requested_by_peer = c.scans_requested_by_peer;
  msg.scans_sent = c.scans_sent;
  msg.scan_bytes_sent = c.scan_bytes_sent;
  msg.scans_received = c.scans_received;
  msg.scan_bytes_received = c.scan_bytes_received;
  msg.receipts_sent = c.receipts_sent;
  msg.receipts_received = c.receipts_received;
  msg.control_bytes_sent = c.control_bytes_sent;
  for (const auto& [reason, count] : c.refused) {
    msg.refused_reasons.push_back(reason);
    msg.refused_counts.push_back(count);
  }
  return msg;
}

}  // namespace

MapStats toMapStatsMsg(const core::information::MapperStage::Stats& stats,
                       const core::information::MapperParams& params, const std::string& robot,
                       const std_msgs::Header& header) {
  MapStats msg;
  msg.header = header;
  msg.robot = robot;
  msg.resolution_m = params.resolution_m;
  msg.entropy_bits = stats.entropy_bits;
  msg.known_volume_m3 = stats.known_volume_m3;
  msg.box_min = tf2::toMsg(params.entropyBoxMin());
  msg.box_max = tf2::toMsg(params.entropyBoxMax());
  msg.keyframes = static_cast<std::uint32_t>(stats.keyframes);
  msg.peer_scans = static_cast<std::uint32_t>(stats.peer_scans);
  msg.pending_peer_scans = static_cast<std::uint32_t>(stats.pending_peer_scans);
  msg.submaps = static_cast<std::uint32_t>(stats.submaps);
  msg.settled_scans = static_cast<std::uint32_t>(stats.settled_scans);
  msg.submap_moves = stats.submap_moves;
  msg.reintegrations = stats.reintegrations;
  msg.map_mb = stats.map_mb;
  msg.submap_mb = stats.submap_mb;
  return msg;
}

BrokerStats toBrokerStatsMsg(const core::routing::BrokerReport& report, const ros::Time& stamp) {
  BrokerStats msg;
  msg.header.stamp = stamp;
  msg.robot = report.robot;
  msg.mode = core::routing::toString(report.mode);
  msg.keyframes = report.keyframes;
  msg.features_sent = report.features_sent;
  msg.kept_scans = static_cast<std::uint32_t>(report.kept_scans);
  msg.scans_sent = report.scans_sent;
  msg.scans_received = report.scans_received;
  for (const auto& [peer, counters] : report.peers) {
    msg.scan_bytes_sent += counters.scan_bytes_sent;
    msg.scan_bytes_received += counters.scan_bytes_received;
    msg.peers.push_back(toPeerRoutingMsg(peer, counters));
  }
  return msg;
}

}  // namespace ccir_mapping::conversions
