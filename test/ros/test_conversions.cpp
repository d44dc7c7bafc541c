#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "ccir_mapping/ros/conversions.h"

namespace ccir_mapping::conversions {
namespace {

sensor_msgs::PointCloud2 velodyneCloud(int points) {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(
      6, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "intensity", 1, sensor_msgs::PointField::FLOAT32, "ring", 1,
      sensor_msgs::PointField::UINT16, "time", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(points);
  return cloud;
}

TEST(Conversions, StampsRoundTripInNanoseconds) {
  const ros::Time time(1700000000, 123456789);
  EXPECT_EQ(toStamp(time), 1700000000123456789LL);
  EXPECT_EQ(toRosTime(toStamp(time)), time);
}

TEST(Conversions, PoseRoundTrip) {
  core::Pose3 pose = core::Pose3::Identity();
  pose.translation() = Eigen::Vector3d(1.0, -2.0, 0.5);
  pose.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const auto back = toPose(toPoseMsg(pose));
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(back->isApprox(pose, 1e-12));
}

TEST(Conversions, RejectsNonFiniteAndNonUnitPoses) {
  geometry_msgs::Pose pose;
  pose.orientation.w = 1.0;
  EXPECT_TRUE(toPose(pose).has_value());
  pose.position.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(toPose(pose).has_value());
  pose.position.x = 0.0;
  pose.orientation.w = 0.0;  // the all-zero quaternion a careless publisher sends
  EXPECT_FALSE(toPose(pose).has_value());
  pose.orientation.w = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(toPose(pose).has_value());
}

TEST(Conversions, AcceptsAVelodyneCloudAndReportsItsFields) {
  CloudFields fields;
  EXPECT_FALSE(checkCloud(velodyneCloud(100), &fields).has_value());
  EXPECT_TRUE(fields.intensity);
  EXPECT_TRUE(fields.ring);
  EXPECT_TRUE(fields.time);
  EXPECT_EQ(missingVelodyneFields(fields), "");
}

TEST(Conversions, ReportsMissingOptionalFields) {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(10);
  CloudFields fields;
  EXPECT_FALSE(checkCloud(cloud, &fields).has_value());
  EXPECT_FALSE(fields.ring);
  EXPECT_FALSE(fields.intensity);
  EXPECT_EQ(missingVelodyneFields(fields), "intensity ring time");
  fields.ring = true;
  EXPECT_EQ(missingVelodyneFields(fields), "intensity time");
}

TEST(Conversions, RejectsMalformedClouds) {
  EXPECT_EQ(*checkCloud(sensor_msgs::PointCloud2(), nullptr), "the cloud is empty");

  auto truncated = velodyneCloud(100);
  truncated.data.resize(truncated.data.size() - 1);
  EXPECT_NE(checkCloud(truncated, nullptr)->find("data holds"), std::string::npos);

  auto no_z = velodyneCloud(10);
  no_z.fields[2].name = "q";
  EXPECT_EQ(*checkCloud(no_z, nullptr), "field 'z' is missing");

  auto double_x = velodyneCloud(10);
  double_x.fields[0].datatype = sensor_msgs::PointField::FLOAT64;
  EXPECT_EQ(*checkCloud(double_x, nullptr), "field 'x' is not one FLOAT32");

  auto bad_row = velodyneCloud(10);
  bad_row.row_step = 4;
  EXPECT_NE(checkCloud(bad_row, nullptr)->find("row_step"), std::string::npos);
}

// Found by fuzz_cloud_conversion: an offset near 2^32 wrapped around in `offset + 4 <=
// point_step`, so the cloud passed and toPcl read 4 GB beyond the point (the manager crashed).
// Any field PCL could map (curvature, ...) must lie inside the point too.
TEST(Conversions, RefusesFieldsBeyondThePointWithoutWrappingAround) {
  auto wrapped_x = velodyneCloud(10);
  wrapped_x.fields[0].offset = 0xFFFFFFFEu;
  EXPECT_EQ(*checkCloud(wrapped_x, nullptr),
            "field 'x' ends at byte 4294967298, beyond point_step 22");
  auto wrapped_intensity = velodyneCloud(10);
  wrapped_intensity.fields[3].offset = 0xFFFFFFFFu;
  EXPECT_TRUE(checkCloud(wrapped_intensity, nullptr));
  auto long_ring = velodyneCloud(10);
  long_ring.fields[4].count = 0x80000000u;  // count * 2 bytes wraps in 32 bits
  EXPECT_TRUE(checkCloud(long_ring, nullptr));
  auto curvature = velodyneCloud(10);
  sensor_msgs::PointField field;
  field.name = "curvature";
  field.datatype = sensor_msgs::PointField::FLOAT32;
  field.count = 1;
  field.offset = 20;  // 20 + 4 > 22
  curvature.fields.push_back(field);
  EXPECT_EQ(*checkCloud(curvature, nullptr),
            "field 'curvature' ends at byte 24, beyond point_step 22");
  Keyframe keyframe;
  keyframe.odom_pose.orientation.w = 1.0;
  keyframe.cloud = curvature;
  pcl::PointCloud<pcl::PointXYZ> points;
  core::Pose3 pose;
  EXPECT_TRUE(toScanPoints(keyframe, &points, &pose));
  pcl::PointCloud<pcl::PointXYZINormal> full;
  EXPECT_TRUE(toKeyframeCloud(curvature, &full));
}

TEST(Conversions, ToPclKeepsLayoutAndReadsIntensityOfAnyWidth) {
  // Organised 2 x 3 cloud with padding at the end of each row and uint8 intensity.
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "intensity", 1, sensor_msgs::PointField::UINT8);
  modifier.resize(6);
  cloud.height = 2;
  cloud.width = 3;
  cloud.row_step = cloud.point_step * 3 + 5;
  cloud.data.assign(cloud.row_step * 2, 0);
  for (std::uint32_t row = 0; row < 2; ++row) {
    for (std::uint32_t column = 0; column < 3; ++column) {
      std::uint8_t* p = cloud.data.data() + row * cloud.row_step + column * cloud.point_step;
      const float xyz[3] = {static_cast<float>(row), static_cast<float>(column), 7.0F};
      std::memcpy(p, xyz, sizeof xyz);
      p[cloud.fields[3].offset] = static_cast<std::uint8_t>(10 * row + column);
    }
  }
  ASSERT_FALSE(checkCloud(cloud, nullptr));
  pcl::PointCloud<pcl::PointXYZI> out;
  toPcl(cloud, &out);
  ASSERT_EQ(out.size(), 6U);
  EXPECT_EQ(out.height, 2U);
  EXPECT_EQ(out.width, 3U);
  EXPECT_EQ(out.at(2, 1).x, 1.0F);  // (column 2, row 1)
  EXPECT_EQ(out.at(2, 1).y, 2.0F);
  EXPECT_EQ(out.at(2, 1).z, 7.0F);
  EXPECT_EQ(out.at(2, 1).intensity, 12.0F);

  // Float intensity of the Velodyne layout; no intensity at all gives 0.
  const auto velodyne = velodyneCloud(10);
  toPcl(velodyne, &out);
  EXPECT_EQ(out.size(), 10U);
  auto plain = velodyneCloud(10);
  plain.fields[3].name = "reflectivity";
  toPcl(plain, &out);
  for (const auto& p : out) EXPECT_EQ(p.intensity, 0.0F);
}

TEST(Conversions, KeyframeRoundTripsThroughItsMessageAndSharedScan) {
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  for (int i = 0; i < 200; ++i) {
    pcl::PointXYZINormal p;
    p.x = 0.1F * i;
    p.y = 3.0F - 0.013F * i;
    p.z = -1.2F;
    p.normal_x = 0.6F;
    p.normal_z = 0.8F;
    p.intensity = static_cast<float>(i % 256);
    cloud.push_back(p);
  }
  std_msgs::Header header;
  header.stamp = ros::Time(12, 345);
  header.frame_id = "robot_a/velodyne";
  core::preprocess::KeyframeSelector::Decision decision;
  decision.id = 42;
  decision.travelled_m = 1.5;
  decision.rotated_rad = 0.25;
  const core::Pose3 odom_pose(Eigen::Translation3d(1, 2, 3));
  const Keyframe keyframe =
      toKeyframeMsg(header, "robot_a", "robot_a/odom", odom_pose, decision, cloud);
  EXPECT_EQ(keyframe.header, header);
  EXPECT_EQ(keyframe.cloud.header, header);
  EXPECT_EQ(keyframe.robot, "robot_a");
  EXPECT_EQ(keyframe.id, 42U);
  EXPECT_EQ(keyframe.odom_frame, "robot_a/odom");
  EXPECT_FLOAT_EQ(keyframe.travelled_m, 1.5F);
  EXPECT_FLOAT_EQ(keyframe.rotated_rad, 0.25F);
  ASSERT_TRUE(toPose(keyframe.odom_pose));
  EXPECT_TRUE(toPose(keyframe.odom_pose)->isApprox(odom_pose));
  pcl::PointCloud<pcl::PointXYZINormal> cloud_back;
  ASSERT_FALSE(toKeyframeCloud(keyframe.cloud, &cloud_back));
  ASSERT_EQ(cloud_back.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_EQ(cloud_back[i].getVector3fMap(), cloud[i].getVector3fMap());
    EXPECT_EQ(cloud_back[i].getNormalVector3fMap(), cloud[i].getNormalVector3fMap());
    EXPECT_EQ(cloud_back[i].intensity, cloud[i].intensity);
  }

  core::routing::WireScan wire;
  pcl::PointCloud<pcl::PointXYZ> xyz;
  ASSERT_FALSE(toWireScan(keyframe, core::routing::BrokerParams{}, &wire, &xyz));
  EXPECT_EQ(wire.robot, "robot_a");
  EXPECT_EQ(wire.id, 42U);
  EXPECT_EQ(wire.stamp, toStamp(header.stamp));
  EXPECT_TRUE(wire.odom_pose.isApprox(odom_pose));
  ASSERT_EQ(xyz.size(), cloud.size());
  EXPECT_EQ(xyz[7].getVector3fMap(), cloud[7].getVector3fMap());
  SharedScan shared = toSharedScanMsg(std::move(wire), header.frame_id, keyframe.odom_frame);
  EXPECT_EQ(shared.encoding, SharedScan::ENCODING_CLOUD);
  EXPECT_EQ(shared.point_count, 200U);
  EXPECT_LT(shared.points.size(), keyframe.cloud.data.size() / 5);

  Keyframe back;
  ASSERT_FALSE(toKeyframe(shared, &back));
  EXPECT_EQ(back.header.stamp, keyframe.header.stamp);
  EXPECT_EQ(back.header.frame_id, keyframe.header.frame_id);
  EXPECT_EQ(back.cloud.header.frame_id, keyframe.header.frame_id);
  EXPECT_EQ(back.robot, "robot_a");
  EXPECT_EQ(back.id, 42U);
  EXPECT_EQ(back.odom_frame, "robot_a/odom");
  EXPECT_DOUBLE_EQ(back.odom_pose.position.y, 2.0);
  EXPECT_EQ(back.travelled_m, 1.5F);
  EXPECT_EQ(back.rotated_rad, 0.25F);
  EXPECT_FALSE(back.drawn_from_mixture);
  pcl::PointCloud<pcl::PointXYZINormal> points;
  ASSERT_FALSE(toKeyframeCloud(back.cloud, &points));  // the layout the Matcher reads
  ASSERT_EQ(points.size(), 200U);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(points[i].x, cloud[i].x, 5e-4);
    EXPECT_NEAR(points[i].y, cloud[i].y, 5e-4);
    EXPECT_NEAR(points[i].normal_x, 0.6, 0.01);
    EXPECT_NEAR(points[i].normal_z, 0.8, 0.01);
    EXPECT_EQ(points[i].intensity, cloud[i].intensity);
  }

  // A teammate's malformed scans are refused with a reason.
  auto too_many = shared;  // more points than this robot accepts
  too_many.point_count = core::routing::kMaxTeammateScanPoints + 1;
  EXPECT_TRUE(toKeyframe(too_many, &back));
  auto wrong_count = shared;
  wrong_count.point_count = 7;
  EXPECT_TRUE(toKeyframe(wrong_count, &back));
  auto garbage = shared;
  garbage.points.resize(garbage.points.size() / 2);
  EXPECT_TRUE(toKeyframe(garbage, &back));
  auto bad_pose = shared;
  bad_pose.odom_pose.orientation.w = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(toKeyframe(bad_pose, &back));
  // A keyframe without normals or a valid pose has no wire form.
  auto velodyne = keyframe;
  velodyne.cloud = velodyneCloud(10);
  EXPECT_TRUE(toWireScan(velodyne, core::routing::BrokerParams{}, &wire));
  auto lost = keyframe;
  lost.odom_pose.orientation.w = 0.0;
  const auto error = toWireScan(lost, core::routing::BrokerParams{}, &wire);
  ASSERT_TRUE(error);
  EXPECT_EQ(*error, "odom_pose is not finite");
}

TEST(Conversions, KeyframeAsAGaussianMixtureAndBack) {
  // A floor 1.2 m under the sensor, its normals up (towards the sensor).
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-8.0F, 8.0F);
  for (int i = 0; i < 2000; ++i) {
    pcl::PointXYZINormal p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = -1.2F;
    p.normal_z = 1.0F;
    cloud.push_back(p);
  }
  core::preprocess::KeyframeSelector::Decision decision;
  decision.id = 42;
  std_msgs::Header header;
  header.frame_id = "robot_a/velodyne";
  const Keyframe keyframe =
      toKeyframeMsg(header, "robot_a", "robot_a/odom", core::Pose3::Identity(), decision, cloud);
  core::routing::BrokerParams gmm;
  gmm.scan_encoding = core::routing::ScanEncoding::kGmm;
  gmm.gmm_max_bytes = 2000;
  core::routing::WireScan wire;
  ASSERT_FALSE(toWireScan(keyframe, gmm, &wire));
  const SharedScan shared = toSharedScanMsg(std::move(wire), header.frame_id, keyframe.odom_frame);
  EXPECT_EQ(shared.encoding, SharedScan::ENCODING_GMM);
  EXPECT_EQ(shared.point_count, 2000U);
  EXPECT_LE(shared.points.size(), 2000U) << "within gmm_max_bytes";

  Keyframe back;
  ASSERT_FALSE(toKeyframe(shared, &back));
  EXPECT_EQ(back.id, 42U);
  EXPECT_TRUE(back.drawn_from_mixture);
  pcl::PointCloud<pcl::PointXYZINormal> sampled;
  ASSERT_FALSE(toKeyframeCloud(back.cloud, &sampled));
  ASSERT_EQ(sampled.size(), 2000U) << "as many points as the keyframe had";
  for (const auto& p : sampled) {
    EXPECT_NEAR(p.z, -1.2, 0.05);
    EXPECT_NEAR(p.normal_z, 1.0, 0.01) << "the floor's normal, towards the sensor";
  }
  Keyframe again;
  ASSERT_FALSE(toKeyframe(shared, &again));
  EXPECT_EQ(again.cloud.data, back.cloud.data) << "sampled with the keyframe id as seed";

  auto too_many = shared;
  too_many.point_count = core::routing::kMaxTeammateScanPoints + 1;
  EXPECT_TRUE(toKeyframe(too_many, &back)) << "more points than this robot accepts";
  auto unknown = shared;
  unknown.encoding = 7;
  const auto error = toKeyframe(unknown, &back);
  ASSERT_TRUE(error);
  EXPECT_EQ(*error, "encoding 7 is unknown");
  auto truncated = shared;
  truncated.points.resize(truncated.points.size() - 3);
  EXPECT_TRUE(toKeyframe(truncated, &back));
  auto as_cloud = shared;
  as_cloud.encoding = SharedScan::ENCODING_CLOUD;
  EXPECT_TRUE(toKeyframe(as_cloud, &back)) << "a mixture is no point encoding";
}

TEST(Conversions, ScanPointsOfAKeyframeOrWhyNot) {
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  for (int i = 0; i < 10; ++i) {
    pcl::PointXYZINormal p;
    p.x = 0.5F * i;
    p.y = -1.0F;
    p.z = 0.25F;
    cloud.push_back(p);
  }
  Keyframe keyframe;
  keyframe.odom_pose = toPoseMsg(core::Pose3(Eigen::Translation3d(1, 2, 3)));
  pcl::toROSMsg(cloud, keyframe.cloud);
  pcl::PointCloud<pcl::PointXYZ> points;
  core::Pose3 pose;
  ASSERT_FALSE(toScanPoints(keyframe, &points, &pose));
  ASSERT_EQ(points.size(), 10U);
  EXPECT_FLOAT_EQ(points[3].x, 1.5F);
  EXPECT_FLOAT_EQ(points[3].y, -1.0F);
  EXPECT_DOUBLE_EQ(pose.translation().z(), 3.0);

  Keyframe unplaced = keyframe;
  unplaced.odom_pose.orientation.w = 0.0;  // zero quaternion
  EXPECT_EQ(toScanPoints(unplaced, &points, &pose), "odom_pose is not finite");
  Keyframe empty = keyframe;
  pcl::toROSMsg(pcl::PointCloud<pcl::PointXYZINormal>(), empty.cloud);
  EXPECT_EQ(toScanPoints(empty, &points, &pose), "the cloud is empty");
  Keyframe truncated = keyframe;
  truncated.cloud.data.resize(truncated.cloud.data.size() / 2);
  EXPECT_TRUE(toScanPoints(truncated, &points, &pose));
}

TEST(Conversions, RoutingMessagesRoundTrip) {
  core::routing::Offer offer;
  offer.provider = "robot_a";
  offer.requester = "robot_b";
  offer.sequence = 9;
  core::routing::OfferEntry entry;
  entry.id = 17;
  entry.pose =
      core::Pose3(Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  entry.correspondences = 12;
  entry.size_bytes = 61234;
  entry.utility = 0.75;
  offer.scans = {entry, entry};
  offer.scans[1].id = 18;
  const ScanOffer msg = toOfferMsg(offer, "robot_a/map");
  EXPECT_EQ(msg.map_frame, "robot_a/map");
  core::routing::Offer back;
  ASSERT_FALSE(toOffer(msg, &back));
  EXPECT_EQ(back.provider, "robot_a");
  EXPECT_EQ(back.requester, "robot_b");
  EXPECT_EQ(back.sequence, 9U);
  ASSERT_EQ(back.scans.size(), 2U);
  EXPECT_EQ(back.scans[1].id, 18U);
  EXPECT_EQ(back.scans[0].correspondences, 12);
  EXPECT_EQ(back.scans[0].size_bytes, 61234U);
  EXPECT_EQ(back.scans[0].utility, 0.75);
  EXPECT_TRUE(back.scans[0].pose.isApprox(entry.pose, 1e-12));
  auto bad = msg;
  bad.scans[1].pose.orientation.w = 5.0;
  EXPECT_TRUE(toOffer(bad, &back));

  const core::routing::Request request{"robot_b", "robot_a", 9, {18, 17}};
  const auto request_back = toRequest(toRequestMsg(request));
  EXPECT_EQ(request_back.requester, "robot_b");
  EXPECT_EQ(request_back.provider, "robot_a");
  EXPECT_EQ(request_back.offer_sequence, 9U);
  EXPECT_EQ(request_back.ids, request.ids);

  const core::routing::Receipt receipt{"robot_b", "robot_a", {18}};
  const auto receipt_back = toReceipt(toReceiptMsg(receipt));
  EXPECT_EQ(receipt_back.receiver, "robot_b");
  EXPECT_EQ(receipt_back.provider, "robot_a");
  EXPECT_EQ(receipt_back.ids, receipt.ids);

  LinkStats link;
  link.connected = true;
  link.budget_bytes_per_s = 150000.0;
  link.total_budget_bytes_per_s = 120000.0;
  link.queued_control_bytes = 17;
  link.queued_bulk_bytes = 4242;
  link.available_tokens_bytes = 65536.5;
  const auto state = toLinkState(link);
  EXPECT_TRUE(state.connected);
  EXPECT_EQ(state.budget_bytes_per_s, 150000.0);
  EXPECT_EQ(state.total_budget_bytes_per_s, 120000.0);
  EXPECT_EQ(state.queued_control_bytes, 17U);
  EXPECT_EQ(state.queued_bulk_bytes, 4242U);
  EXPECT_EQ(state.available_tokens_bytes, 65536.5);

  core::routing::BrokerReport report;
  report.robot = "robot_a";
  report.mode = core::routing::RoutingMode::kFixedRate;
  report.keyframes = 9;
  report.features_sent = 8;
  report.kept_scans = 7;
  report.scans_sent = 4;
  report.scans_received = 2;
  report.peers["robot_b"].scans_sent = 3;
  report.peers["robot_b"].scan_bytes_sent = 300;
  report.peers["robot_b"].refused["evicted"] = 2;
  report.peers["robot_c"].scan_bytes_sent = 20;
  report.peers["robot_c"].scan_bytes_received = 50;
  const BrokerStats stats = toBrokerStatsMsg(report, ros::Time(5));
  EXPECT_EQ(stats.header.stamp, ros::Time(5));
  EXPECT_EQ(stats.robot, "robot_a");
  EXPECT_EQ(stats.mode, "fixed_rate");
  EXPECT_EQ(stats.keyframes, 9U);
  EXPECT_EQ(stats.features_sent, 8U);
  EXPECT_EQ(stats.kept_scans, 7U);
  EXPECT_EQ(stats.scans_sent, 4U);
  EXPECT_EQ(stats.scans_received, 2U);
  EXPECT_EQ(stats.scan_bytes_sent, 320U);
  EXPECT_EQ(stats.scan_bytes_received, 50U);
  ASSERT_EQ(stats.peers.size(), 2U);
  const PeerRouting& routing = stats.peers[0];
  EXPECT_EQ(routing.peer, "robot_b");
  EXPECT_EQ(routing.scans_sent, 3U);
  EXPECT_EQ(routing.scan_bytes_sent, 300U);
  ASSERT_EQ(routing.refused_reasons.size(), 1U);
  EXPECT_EQ(routing.refused_reasons[0], "evicted");
  EXPECT_EQ(routing.refused_counts[0], 2U);
  EXPECT_EQ(stats.peers[1].peer, "robot_c");
}

core::Pose3 somePose(double x, double angle) {
  core::Pose3 pose = core::Pose3::Identity();
  pose.translation() << x, -1.5, 0.25;
  pose.linear() =
      Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return pose;
}

core::Matrix6 someCovariance() {
  core::Matrix6 covariance;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) covariance(r, c) = 10 * r + c;  // not symmetric: order shows
  }
  return covariance;
}

TEST(Conversions, TransformStampedNamesBothFrames) {
  const auto msg =
      toTransformStampedMsg(ros::Time(7), "robot_a/map", "robot_a/odom", somePose(3.0, 0.2));
  EXPECT_EQ(msg.header.stamp, ros::Time(7));
  EXPECT_EQ(msg.header.frame_id, "robot_a/map");
  EXPECT_EQ(msg.child_frame_id, "robot_a/odom");
  const auto pose = toPose(msg.transform);
  ASSERT_TRUE(pose);
  EXPECT_TRUE(pose->isApprox(somePose(3.0, 0.2), 1e-12));
}

TEST(Conversions, CovariancesAreRowMajor) {
  const auto msg = toCovarianceMsg(someCovariance());
  EXPECT_EQ(msg[1], 1.0);
  EXPECT_EQ(msg[6], 10.0);
  EXPECT_EQ(msg[35], 55.0);
  EXPECT_EQ(toMatrix6(msg), someCovariance());
}

TEST(Conversions, LoopClosureRoundTrip) {
  core::pose_graph::LoopClosureData loop;
  loop.robot_from = "robot_a";
  loop.keyframe_from = 12;
  loop.robot_to = "robot_b";
  loop.keyframe_to = 345;
  loop.relative = somePose(2.0, 0.3);
  loop.covariance = someCovariance();
  loop.odom_pose_from = somePose(-4.0, 1.1);
  loop.odom_pose_to = somePose(7.0, -0.4);
  loop.match_score = 0.75;
  loop.new_place_probability = 0.125;
  loop.fitness_m2 = 0.04;
  loop.inliers = 31;
  loop.method = "fabmap";
  core::pose_graph::LoopClosureData back;
  ASSERT_TRUE(toLoopClosure(toLoopClosureMsg(loop), &back));
  EXPECT_EQ(back.match_score, 0.75);
  EXPECT_EQ(back.new_place_probability, 0.125);
  EXPECT_EQ(back.fitness_m2, 0.04);
  EXPECT_EQ(back.inliers, 31);
  EXPECT_EQ(back.method, "fabmap");
  EXPECT_EQ(back.robot_from, "robot_a");
  EXPECT_EQ(back.keyframe_from, 12U);
  EXPECT_EQ(back.robot_to, "robot_b");
  EXPECT_EQ(back.keyframe_to, 345U);
  EXPECT_TRUE(back.relative.isApprox(loop.relative, 1e-12));
  EXPECT_EQ(back.covariance, loop.covariance);
  ASSERT_TRUE(back.odom_pose_from);
  EXPECT_TRUE(back.odom_pose_from->isApprox(*loop.odom_pose_from, 1e-12));
  ASSERT_TRUE(back.odom_pose_to);
  EXPECT_TRUE(back.odom_pose_to->isApprox(*loop.odom_pose_to, 1e-12));
  // Without odometry poses the message's stay unset (a zero quaternion): none comes back.
  loop.odom_pose_from.reset();
  loop.odom_pose_to.reset();
  ASSERT_TRUE(toLoopClosure(toLoopClosureMsg(loop), &back));
  EXPECT_FALSE(back.odom_pose_from);
  EXPECT_FALSE(back.odom_pose_to);
  // A relative pose that is not finite is refused.
  LoopClosure broken = toLoopClosureMsg(loop);
  broken.relative_pose.position.z = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(toLoopClosure(broken, &back));
}

TEST(Conversions, TeamTransformCarriesTheEstimate) {
  core::backend::TeamEstimate estimate;
  estimate.peer = "robot_c";
  estimate.candidates = 14;
  estimate.alignment.found = true;
  estimate.alignment.transform = somePose(7.0, -0.4);
  estimate.alignment.covariance = someCovariance();
  estimate.alignment.inlier_count = 12;
  estimate.alignment.runner_up_inliers = 3;
  const TeamTransform msg = toTeamTransformMsg(estimate, "robot_a/map", ros::Time(105, 5));
  EXPECT_EQ(msg.header.frame_id, "robot_a/map");
  EXPECT_EQ(msg.header.stamp, ros::Time(105, 5));
  EXPECT_EQ(msg.peer, "robot_c");
  EXPECT_EQ(msg.child_frame_id, "robot_c/map");
  EXPECT_TRUE(msg.valid);
  const auto transform = toPose(msg.transform);
  ASSERT_TRUE(transform);
  EXPECT_TRUE(transform->isApprox(estimate.alignment.transform, 1e-12));
  EXPECT_EQ(toMatrix6(msg.covariance), someCovariance());
  EXPECT_EQ(msg.inliers, 12U);
  EXPECT_EQ(msg.candidates, 14U);
  EXPECT_DOUBLE_EQ(msg.margin, 4.0);
  estimate.alignment.runner_up_inliers = 0;
  EXPECT_DOUBLE_EQ(toTeamTransformMsg(estimate, "robot_a/map", ros::Time(1)).margin, 12.0);
  // The receiver's view: the peer's frame while valid and finite, nothing otherwise.
  const auto frame = toTeamFrame(msg);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->isApprox(estimate.alignment.transform, 1e-12));
  estimate.alignment.found = false;
  EXPECT_FALSE(toTeamFrame(toTeamTransformMsg(estimate, "robot_a/map", ros::Time(1))));
  TeamTransform broken = msg;
  broken.transform.translation.x = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(toTeamFrame(broken));
}

TEST(Conversions, AnyMessageCrossesTheBridgeAsBytesWithItsDescription) {
  const geometry_msgs::Pose pose = toPoseMsg(somePose(1.0, 0.2));
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(pose));
  ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(out, pose);
  core::transport::InboxMessage message;
  message.topic.name = "inbox/pose";
  message.topic.type = ros::message_traits::datatype(pose);
  message.topic.md5 = ros::message_traits::md5sum(pose);
  message.topic.definition = ros::message_traits::definition(pose);
  message.bytes = bytes;
  std::string error;
  const auto shifter = toShapeShifter(message, &error);
  ASSERT_TRUE(shifter) << error;
  const auto back = shifter->instantiate<geometry_msgs::Pose>();
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, pose);
  EXPECT_EQ(toBytes(*shifter), bytes);

  core::transport::ForwardedTopic forwarded;
  forwarded.topic = "outbox/pose";
  forwarded.reliable = false;
  forwarded.compress = true;
  const ros::M_string latching = {{"latching", "1"}, {"type", "geometry_msgs/Pose"}};
  const auto topic = toTopicInfo(*shifter, forwarded, &latching);
  EXPECT_EQ(topic.name, "inbox/pose");
  EXPECT_EQ(topic.type, "geometry_msgs/Pose");
  EXPECT_EQ(topic.md5, message.topic.md5);
  EXPECT_EQ(topic.definition, message.topic.definition);
  EXPECT_TRUE(topic.latched);
  EXPECT_FALSE(topic.reliable);
  EXPECT_TRUE(topic.compressed);
  EXPECT_FALSE(toTopicInfo(*shifter, forwarded, nullptr).latched);
  const ros::M_string not_latching = {{"latching", "0"}};
  EXPECT_FALSE(toTopicInfo(*shifter, forwarded, &not_latching).latched);

  message.topic.md5 = "short";
  EXPECT_FALSE(toShapeShifter(message, &error));
  EXPECT_EQ(error, "type 'geometry_msgs/Pose', md5 'short'");
  message.topic.md5 = topic.md5;
  message.topic.type = "NoPackage";
  EXPECT_FALSE(toShapeShifter(message, &error));
}

TEST(Conversions, LinkStatsReportALinkWithItsBudgetsAndTheDropsThatHappened) {
  core::transport::LinkReport report;
  report.peer = "robot_b";
  report.address = "10.0.0.2:4000";
  report.connected = true;
  report.sent.bytes_sent = 5000;
  report.sent.messages_sent = 7;
  report.received.bytes_received = 900;
  report.received.messages_received = 3;
  report.received.peer_restarts = 2;
  report.queued_control = 2;
  report.queued_bulk = 1;
  report.queued_control_bytes = 300;
  report.queued_bulk_bytes = 60000;
  report.available_tokens_bytes = 1234.5;
  report.drops = {{"queue_full", 4}, {"too_old", 0}};
  report.silent_s = 2.5;
  core::transport::BridgeParams params;
  params.budget_bytes_per_s = 100000;
  params.total_budget_bytes_per_s = 150000;
  const LinkStats msg = toLinkStatsMsg(report, "robot_a", params, ros::Time(100), 812.5);
  EXPECT_EQ(msg.header.stamp, ros::Time(100));
  EXPECT_EQ(msg.robot, "robot_a");
  EXPECT_EQ(msg.peer, "robot_b");
  EXPECT_TRUE(msg.connected);
  EXPECT_EQ(msg.address, "10.0.0.2:4000");
  EXPECT_EQ(msg.bytes_sent, 5000U);
  EXPECT_EQ(msg.messages_sent, 7U);
  EXPECT_EQ(msg.bytes_received, 900U);
  EXPECT_EQ(msg.messages_received, 3U);
  EXPECT_EQ(msg.peer_restarts, 2U);
  EXPECT_DOUBLE_EQ(msg.send_rate_bytes_per_s, 812.5);
  EXPECT_DOUBLE_EQ(msg.budget_bytes_per_s, 100000);
  EXPECT_DOUBLE_EQ(msg.total_budget_bytes_per_s, 150000);
  EXPECT_EQ(msg.queued_control, 2U);
  EXPECT_EQ(msg.queued_bulk_bytes, 60000U);
  EXPECT_DOUBLE_EQ(msg.available_tokens_bytes, 1234.5);
  EXPECT_EQ(msg.drop_reasons, (std::vector<std::string>{"queue_full"}));
  EXPECT_EQ(msg.drop_counts, (std::vector<std::uint64_t>{4}));
  EXPECT_EQ(msg.last_seen, ros::Time(97.5));
  // The Broker's view of the same link.
  const auto state = toLinkState(msg);
  EXPECT_TRUE(state.connected);
  EXPECT_EQ(state.queued_bulk_bytes, 60000U);
  EXPECT_DOUBLE_EQ(state.available_tokens_bytes, 1234.5);
  report.silent_s = -1.0;  // never heard
  EXPECT_EQ(toLinkStatsMsg(report, "robot_a", params, ros::Time(100), 0.0).last_seen, ros::Time());
}

TEST(Conversions, MapStatsCarryTheMapsFiguresAndItsBox) {
  core::information::MapperStage::Stats stats;
  stats.entropy_bits = 1234.5;
  stats.known_volume_m3 = 67.25;
  stats.keyframes = 9;
  stats.peer_scans = 4;
  stats.pending_peer_scans = 2;
  stats.submaps = 6;
  stats.settled_scans = 5;
  stats.submap_moves = 3;
  stats.reintegrations = 1;
  stats.map_mb = 12.5;
  stats.submap_mb = 3.25;
  core::information::MapperParams params;
  params.resolution_m = 0.2;
  params.entropy_box_half_width_m = 30.0;
  std_msgs::Header header;
  header.frame_id = "robot_a/map";
  const MapStats msg = toMapStatsMsg(stats, params, "robot_a", header);
  EXPECT_EQ(msg.header.frame_id, "robot_a/map");
  EXPECT_EQ(msg.robot, "robot_a");
  EXPECT_DOUBLE_EQ(msg.resolution_m, 0.2);
  EXPECT_DOUBLE_EQ(msg.entropy_bits, 1234.5);
  EXPECT_DOUBLE_EQ(msg.known_volume_m3, 67.25);
  EXPECT_DOUBLE_EQ(msg.box_min.x, params.entropyBoxMin().x());
  EXPECT_DOUBLE_EQ(msg.box_max.z, params.entropyBoxMax().z());
  EXPECT_EQ(msg.keyframes, 9U);
  EXPECT_EQ(msg.peer_scans, 4U);
  EXPECT_EQ(msg.pending_peer_scans, 2U);
  EXPECT_EQ(msg.submaps, 6U);
  EXPECT_EQ(msg.settled_scans, 5U);
  EXPECT_EQ(msg.submap_moves, 3U);
  EXPECT_EQ(msg.reintegrations, 1U);
  EXPECT_DOUBLE_EQ(msg.map_mb, 12.5);
  EXPECT_DOUBLE_EQ(msg.submap_mb, 3.25);
}

TEST(Conversions, TfCarriesTheOdometryCorrectionAndTheTransformsFound) {
  core::backend::BackendSnapshot snapshot;
  snapshot.poses = {somePose(0.0, 0.0), somePose(5.0, 0.3)};
  snapshot.latest_odom_pose = somePose(4.0, 0.1);
  core::backend::TeamEstimate found;
  found.peer = "robot_b";
  found.alignment.found = true;
  found.alignment.transform = somePose(-3.0, 0.7);
  core::backend::TeamEstimate not_yet;
  not_yet.peer = "robot_c";
  snapshot.team = {found, not_yet};
  const auto transforms = toTfMsgs(snapshot, "robot_a/map", "robot_a/odom", ros::Time(9));
  ASSERT_EQ(transforms.size(), 2U);
  EXPECT_EQ(transforms[0].child_frame_id, "robot_a/odom");
  EXPECT_EQ(transforms[0].header.stamp, ros::Time(9));
  const auto map_from_odom = toPose(transforms[0].transform);
  ASSERT_TRUE(map_from_odom);
  // The odometry pose of the newest keyframe, corrected, is its optimised pose.
  EXPECT_TRUE((*map_from_odom * snapshot.latest_odom_pose).isApprox(snapshot.poses.back(), 1e-9));
  EXPECT_EQ(transforms[1].header.frame_id, "robot_a/map");
  EXPECT_EQ(transforms[1].child_frame_id, "robot_b/map");
  EXPECT_TRUE(toPose(transforms[1].transform)->isApprox(found.alignment.transform, 1e-12));
}

TEST(Conversions, TeamKeyframePosesRoundTrip) {
  core::backend::PeerKeyframes keyframes;
  keyframes.robot = "robot_b";
  keyframes.ids = {3, 8};
  keyframes.poses = {core::Pose3(Eigen::Translation3d(1, 2, 3)),
                     core::Pose3(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()))};
  const TeamKeyframePoses msg = toTeamKeyframePosesMsg(keyframes, "robot_a/map", ros::Time(5));
  EXPECT_EQ(msg.header.frame_id, "robot_a/map");
  EXPECT_EQ(msg.header.stamp, ros::Time(5));
  EXPECT_EQ(msg.robot, "robot_b");
  const auto poses = toKeyframePoses(msg);
  ASSERT_TRUE(poses);
  ASSERT_EQ(poses->size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ((*poses)[i].first, keyframes.ids[i]);
    EXPECT_TRUE((*poses)[i].second.isApprox(keyframes.poses[i], 1e-12));
  }
  TeamKeyframePoses broken = msg;
  broken.poses[1].position.x = std::nan("");
  EXPECT_FALSE(toKeyframePoses(broken)) << "a non-finite pose";
  broken = msg;
  broken.keyframe_ids.pop_back();
  EXPECT_FALSE(toKeyframePoses(broken)) << "lengths differ";
}

TEST(Conversions, UncertaintyFeaturesAndCorrespondences) {
  std_msgs::Header header;
  header.stamp = ros::Time(3);
  header.frame_id = "robot_a/map";
  const KeyframeUncertainty uncertainty =
      toKeyframeUncertaintyMsg("robot_a", header, {4, 9}, {0.25, 1.5});
  EXPECT_EQ(uncertainty.header.frame_id, "robot_a/map");
  EXPECT_EQ(uncertainty.robot, "robot_a");
  const auto variances = toVariances(uncertainty);
  ASSERT_TRUE(variances);
  EXPECT_EQ(*variances, (std::vector<std::pair<core::KeyframeId, double>>{{4, 0.25}, {9, 1.5}}));
  KeyframeUncertainty short_one = uncertainty;
  short_one.position_variance_m2.pop_back();
  EXPECT_FALSE(toVariances(short_one));

  const core::place_recognition::KeyframeWords words{"robot_a", 17,          toStamp(header.stamp),
                                                     "cafe01",  {2, 5, 400}, 260};
  const KeyframeFeatures features = toKeyframeFeaturesMsg(header, words);
  EXPECT_EQ(features.header.stamp, ros::Time(3));
  EXPECT_EQ(features.robot, "robot_a");
  EXPECT_EQ(features.keyframe_id, 17U);
  EXPECT_EQ(features.vocabulary_hash, "cafe01");
  EXPECT_EQ(features.words, (std::vector<std::uint32_t>{2, 5, 400}));
  EXPECT_EQ(features.descriptor_count, 260U);
  const auto words_back = toKeyframeWords(features);
  EXPECT_EQ(words_back.robot, words.robot);
  EXPECT_EQ(words_back.id, words.id);
  EXPECT_EQ(words_back.stamp, words.stamp);
  EXPECT_EQ(words_back.vocabulary_hash, words.vocabulary_hash);
  EXPECT_EQ(words_back.words, words.words);
  EXPECT_EQ(words_back.descriptor_count, words.descriptor_count);

  const core::place_recognition::KeyframeCorrespondences counts{"robot_b", 44, {{12, 30}, {3, 7}}};
  const Correspondences c = toCorrespondencesMsg("robot_a", counts, ros::Time(8));
  EXPECT_EQ(c.robot, "robot_a");
  EXPECT_EQ(c.peer, "robot_b");
  EXPECT_EQ(c.peer_keyframe_id, 44U);
  EXPECT_EQ(c.header.stamp, ros::Time(8));
  const auto back = toKeyframeCorrespondences(c);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->peer, counts.peer);
  EXPECT_EQ(back->peer_keyframe, counts.peer_keyframe);
  EXPECT_EQ(back->counts, counts.counts);
  Correspondences broken = c;
  broken.counts.push_back(1);
  EXPECT_FALSE(toKeyframeCorrespondences(broken));
}

TEST(Conversions, PathRoundTripsAndSkipsBrokenPoses) {
  const std::vector<core::Stamp> stamps = {100000000000LL, 101000000001LL};
  const std::vector<core::Pose3> poses = {somePose(1.0, 0.1), somePose(2.0, 0.2)};
  nav_msgs::Path path = toPathMsg(stamps, poses, "robot_a/map");
  EXPECT_EQ(path.header.frame_id, "robot_a/map");
  EXPECT_EQ(toStamp(path.header.stamp), stamps.back());
  int skipped = 0;
  auto back = toStampedPoses(path, &skipped);
  ASSERT_EQ(back.size(), 2U);
  EXPECT_EQ(skipped, 0);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].first, stamps[i]);
    EXPECT_TRUE(back[i].second.isApprox(poses[i], 1e-12));
    EXPECT_EQ(path.poses[i].header.frame_id, "robot_a/map");
  }
  path.poses[0].pose.orientation.w = std::numeric_limits<double>::infinity();
  back = toStampedPoses(path, &skipped);
  ASSERT_EQ(back.size(), 1U);
  EXPECT_EQ(back[0].first, stamps[1]);
  EXPECT_EQ(skipped, 1);
}

TEST(Conversions, LoopMarkersDrawEachKindAndDeleteEmptyOnes) {
  core::backend::LoopLine kept;
  kept.accepted = true;
  kept.to = Eigen::Vector3d(1, 2, 3);
  core::backend::LoopLine inter;
  inter.inter_robot = true;
  inter.accepted = true;
  const auto markers = toLoopMarkersMsg({kept, inter, kept}, "robot_a/map", ros::Time(3));
  ASSERT_EQ(markers.markers.size(), 3U);
  EXPECT_EQ(markers.markers[0].ns, "loops kept");
  EXPECT_EQ(markers.markers[0].points.size(), 4U);
  EXPECT_EQ(markers.markers[0].points[1].z, 3.0);
  EXPECT_EQ(markers.markers[0].action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(markers.markers[1].action, visualization_msgs::Marker::DELETE) << "none rejected";
  EXPECT_EQ(markers.markers[2].points.size(), 2U);
  // A rejected closure is red whichever robots it joins.
  inter.accepted = false;
  const auto rejected = toLoopMarkersMsg({kept, inter}, "robot_a/map", ros::Time(3));
  EXPECT_EQ(rejected.markers[1].points.size(), 2U);
  EXPECT_EQ(rejected.markers[2].action, visualization_msgs::Marker::DELETE);
  for (const auto& m : markers.markers) EXPECT_EQ(m.header.frame_id, "robot_a/map");
}

}  // namespace
}  // namespace ccir_mapping::conversions
