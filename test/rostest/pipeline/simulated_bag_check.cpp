// Plays a simulated mission's bag (~bag) into one robot's pipeline, paced by /clock like
// `rosbag play --clock`, and checks the keyframes against the bag: count and spacing for the
// keyframe thresholds, poses equal to the recorded odometry, scan stamps and frames kept.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>
#include <Eigen/Geometry>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/ros/conversions.h"
#include "wait_for.h"

namespace ccir_mapping {
namespace {

using testing::waitFor;

/// Thresholds in config/robot.yaml (preprocessor section).
constexpr double kKeyframeDistanceM = 1.0;
constexpr double kKeyframeRotationRad = 15.0 * M_PI / 180.0;

double yawOf(const core::Pose3& pose) {
  return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0));
}

TEST(SimulatedBag, KeyframesFollowTheRecordedOdometry) {
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  const std::string bag_file = private_nh.param<std::string>("bag", "");
  const double rate = private_nh.param("rate", 1.0);
  const std::string robot = private_nh.param<std::string>("robot", "robot_a");
  ASSERT_FALSE(bag_file.empty()) << "set ~bag";

  std::vector<Keyframe::ConstPtr> keyframes;
  ros::Subscriber keyframe_sub = nh.subscribe<Keyframe>(
      "keyframes", 1000, [&](const Keyframe::ConstPtr& k) { keyframes.push_back(k); });
  ros::Publisher clock_pub = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("velodyne_points", 50);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 500);
  ros::Publisher tf_pub = nh.advertise<tf2_msgs::TFMessage>("/tf", 500);
  ros::Publisher tf_static_pub = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  ASSERT_TRUE(waitFor(
      [&] {
        return cloud_pub.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0 &&
               keyframe_sub.getNumPublishers() > 0;
      },
      30.0))
      << "the pipeline did not come up";

  rosbag::Bag bag(bag_file);
  rosbag::View view(bag, rosbag::TopicQuery({"/velodyne_points", "/odom", "/tf", "/tf_static"}));
  std::map<ros::Time, core::Pose3> odometry;  // base_link in odom, by stamp
  std::vector<ros::Time> scan_stamps;
  core::Pose3 mount = core::Pose3::Identity();
  const ros::WallTime wall_start = ros::WallTime::now();
  const ros::Time bag_start = view.getBeginTime();
  for (const rosbag::MessageInstance& m : view) {
    // Pace like rosbag play: message time maps to wall time through `rate`.
    const ros::WallTime due =
        wall_start + ros::WallDuration((m.getTime() - bag_start).toSec() / rate);
    ros::WallTime::sleepUntil(due);
    rosgraph_msgs::Clock clock;
    clock.clock = m.getTime();
    clock_pub.publish(clock);
    if (m.getTopic() == "/velodyne_points") {
      const auto cloud = m.instantiate<sensor_msgs::PointCloud2>();
      scan_stamps.push_back(cloud->header.stamp);
      cloud_pub.publish(cloud);
    } else if (m.getTopic() == "/odom") {
      const auto odom = m.instantiate<nav_msgs::Odometry>();
      odometry[odom->header.stamp] = *conversions::toPose(odom->pose.pose);
      odom_pub.publish(odom);
    } else if (m.getTopic() == "/tf") {
      tf_pub.publish(m.instantiate<tf2_msgs::TFMessage>());
    } else {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      mount = *conversions::toPose(tf->transforms.at(0).transform);
      tf_static_pub.publish(tf);
    }
    ros::spinOnce();
  }
  ASSERT_GT(scan_stamps.size(), 50U) << "a few seconds of scans expected in " << bag_file;

  // Path length and rotation the odometry recorded while scans were taken.
  double path_m = 0.0;
  double turned_rad = 0.0;
  for (auto it = std::next(odometry.begin()); it != odometry.end(); ++it) {
    if (it->first > scan_stamps.back()) break;
    const core::Pose3 step = std::prev(it)->second.inverse() * it->second;
    path_m += step.translation().norm();
    turned_rad += std::abs(yawOf(step));
  }
  const size_t fewest = static_cast<size_t>(path_m / kKeyframeDistanceM);
  const size_t most = fewest + static_cast<size_t>(turned_rad / kKeyframeRotationRad) + 2;

  // Done when the Preprocessor reports every scan in and as many keyframes out as arrived here.
  // Simulated time keeps moving (as a driver's clock would) so that its diagnostics timer fires.
  double scans_in = -1.0;
  double keyframes_out = -1.0;
  std::string ms_per_keyframe;
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& array) {
        for (const auto& status : array->status) {
          if (status.name.find("preprocessor: flow") == std::string::npos) continue;
          for (const auto& entry : status.values) {
            if (entry.key == "in velodyne_points messages") scans_in = std::stod(entry.value);
            if (entry.key == "out keyframes messages") keyframes_out = std::stod(entry.value);
            if (entry.key == "ms per keyframe (mean)") ms_per_keyframe = entry.value;
          }
        }
      });
  ros::Time now = view.getEndTime();
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && ros::WallTime::now() < deadline &&
         !(scans_in == static_cast<double>(scan_stamps.size()) &&
           keyframes_out == static_cast<double>(keyframes.size()))) {
    now += ros::Duration(0.05);
    rosgraph_msgs::Clock clock;
    clock.clock = now;
    clock_pub.publish(clock);
    ros::WallDuration(0.01).sleep();  // 5x real time, like a fast rosbag play
    ros::spinOnce();
  }
  ASSERT_EQ(scans_in, static_cast<double>(scan_stamps.size())) << "scans the Preprocessor took in";
  ASSERT_EQ(keyframes_out, static_cast<double>(keyframes.size())) << "keyframes it reports";
  ROS_INFO("%zu scans, %zu keyframes (%s ms each); odometry path %.2f m, turned %.2f rad",
           scan_stamps.size(), keyframes.size(), ms_per_keyframe.c_str(), path_m, turned_rad);
  EXPECT_GE(keyframes.size(), fewest) << "path " << path_m << " m";
  EXPECT_LE(keyframes.size(), most) << "path " << path_m << " m, turned " << turned_rad << " rad";

  for (size_t i = 0; i < keyframes.size(); ++i) {
    const Keyframe& k = *keyframes[i];
    SCOPED_TRACE("keyframe " + std::to_string(i));
    EXPECT_EQ(k.id, i);
    EXPECT_EQ(k.robot, robot);
    EXPECT_EQ(k.odom_frame, robot + "/odom");
    EXPECT_EQ(k.header.frame_id, robot + "/velodyne");
    // The preprocessed scan: down-sampled, with unit normals facing the sensor.
    EXPECT_EQ(k.cloud.header.frame_id, k.header.frame_id);
    EXPECT_GT(k.cloud.width * k.cloud.height, 2000U);
    EXPECT_LT(k.cloud.width * k.cloud.height, 28800U);
    for (sensor_msgs::PointCloud2ConstIterator<float> p(k.cloud, "x"), n(k.cloud, "normal_x");
         p != p.end(); ++p, ++n) {
      const Eigen::Vector3f point(p[0], p[1], p[2]);
      const Eigen::Vector3f normal(n[0], n[1], n[2]);
      ASSERT_TRUE(point.allFinite());
      ASSERT_NEAR(normal.norm(), 1.0F, 1e-3F);
      ASSERT_LE(normal.dot(point), 1e-3F);
    }
    ASSERT_TRUE(std::binary_search(scan_stamps.begin(), scan_stamps.end(), k.header.stamp))
        << "stamp " << k.header.stamp << " is not a scan's";
    // The pose is the recorded odometry at the scan's stamp (50 Hz odometry, 10 Hz scans: the
    // stamps coincide), with the sensor mount.
    const auto odom = odometry.find(k.header.stamp);
    ASSERT_NE(odom, odometry.end());
    const core::Pose3 expected = odom->second * mount;
    const core::Pose3 actual = *conversions::toPose(k.odom_pose);
    EXPECT_LT((actual.translation() - expected.translation()).norm(), 1e-3);
    EXPECT_LT(std::abs(yawOf(expected.inverse() * actual)), 1e-3);
    if (i == 0) continue;
    // Spacing: a keyframe is made once either threshold is passed, within one scan's motion.
    const core::Pose3 previous = *conversions::toPose(keyframes[i - 1]->odom_pose);
    const core::Pose3 step = previous.inverse() * actual;
    EXPECT_NEAR(k.travelled_m, step.translation().norm(), 0.05);
    EXPECT_TRUE(k.travelled_m >= kKeyframeDistanceM - 1e-3 ||
                k.rotated_rad >= kKeyframeRotationRad - 1e-3)
        << "travelled " << k.travelled_m << " m, rotated " << k.rotated_rad << " rad";
    EXPECT_LT(k.travelled_m, kKeyframeDistanceM + 0.15);
  }
}

}  // namespace
}  // namespace ccir_mapping

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "simulated_bag_check");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
