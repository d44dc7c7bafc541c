// Where the Preprocessor places a scan (ScanPlacement): from tf at the scan's stamp, or from
// odometry (interpolated, refused when in other frames, not finite or going back) and the static
// sensor mount; scans wait in arrival order until what places them has arrived, or are given up
// with a reason.
#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/scan_placement.h"

namespace ccir_mapping {
namespace {

ros_params::PreprocessorSettings settings(const std::string& odom_source) {
  ros_params::PreprocessorSettings s;
  s.frames.odom_frame = "r/odom";
  s.frames.base_frame = "r/base_link";
  s.odom_source = odom_source;
  return s;
}

nav_msgs::Odometry odometry(double t, double x, const std::string& parent = "r/odom") {
  nav_msgs::Odometry msg;
  msg.header.stamp = ros::Time(t);
  msg.header.frame_id = parent;
  msg.child_frame_id = "r/base_link";
  msg.pose.pose.position.x = x;
  msg.pose.pose.orientation.w = 1.0;
  return msg;
}

geometry_msgs::TransformStamped transform(const std::string& parent, const std::string& child,
                                          double t, double x, double z = 0.0) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = ros::Time(t);
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  msg.transform.translation.x = x;
  msg.transform.translation.z = z;
  msg.transform.rotation.w = 1.0;
  return msg;
}

TEST(ScanPlacement, FromOdometryAndTheSensorMount) {
  ScanPlacement placement(settings("topic"), "/r/odom");
  std::string why;
  EXPECT_FALSE(placement.placeable("r/velodyne", ros::Time(1.05), &why));
  EXPECT_NE(why.find("no odometry at or after its stamp on '/r/odom'"), std::string::npos) << why;

  EXPECT_FALSE(placement.addOdometry(odometry(1.0, 0.0)));
  EXPECT_FALSE(placement.addOdometry(odometry(1.1, 1.0)));
  const auto wrong = placement.addOdometry(odometry(3.0, 2.0, "other/odom"));
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->problem, "in other frames");
  EXPECT_EQ(wrong->detail, "'other/odom' -> 'r/base_link', expected 'r/odom' -> 'r/base_link'");
  const auto back = placement.addOdometry(odometry(1.05, 2.0));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->problem, "stamp not after the previous one");
  const auto not_finite = placement.addOdometry(odometry(3.0, std::nan("")));
  ASSERT_TRUE(not_finite);
  EXPECT_EQ(not_finite->problem, "pose is not finite");

  // Odometry covers the stamp, but the mount is not on tf yet.
  EXPECT_TRUE(placement.placeable("r/base_link", ros::Time(1.05)));
  EXPECT_FALSE(placement.placeable("r/velodyne", ros::Time(1.05), &why));
  EXPECT_FALSE(placement.placeable("r/base_link", ros::Time(1.2)));
  placement.tf().setTransform(transform("r/base_link", "r/velodyne", 0.0, 0.2, 0.5), "test", true);
  ASSERT_TRUE(placement.placeable("r/velodyne", ros::Time(1.05), &why)) << why;
  const auto pose = placement.sensorPose("r/velodyne", ros::Time(1.05), &why);
  ASSERT_TRUE(pose) << why;
  EXPECT_NEAR(pose->translation().x(), 0.5 + 0.2, 1e-9);
  EXPECT_NEAR(pose->translation().z(), 0.5, 1e-9);
}

TEST(ScanPlacement, FromTfAtTheScansStamp) {
  ScanPlacement placement(settings("tf"), "/r/odom");
  placement.tf().setTransform(transform("r/odom", "r/base_link", 1.0, 0.0), "test");
  placement.tf().setTransform(transform("r/odom", "r/base_link", 2.0, 2.0), "test");
  placement.tf().setTransform(transform("r/base_link", "r/velodyne", 0.0, 0.1), "test", true);
  std::string why;
  ASSERT_TRUE(placement.placeable("r/velodyne", ros::Time(1.25), &why)) << why;
  const auto pose = placement.sensorPose("r/velodyne", ros::Time(1.25), &why);
  ASSERT_TRUE(pose) << why;
  EXPECT_NEAR(pose->translation().x(), 0.5 + 0.1, 1e-9);
  EXPECT_FALSE(placement.placeable("r/velodyne", ros::Time(2.5), &why));
  EXPECT_FALSE(why.empty());
  EXPECT_FALSE(placement.sensorPose("r/velodyne", ros::Time(2.5), &why));
  EXPECT_FALSE(placement.sensorPose("no_such_frame", ros::Time(1.05), &why));
  EXPECT_NE(why.find("no_such_frame"), std::string::npos) << why;
}

sensor_msgs::PointCloud2::ConstPtr scan(double t, const std::string& frame = "r/base_link") {
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header.stamp = ros::Time(t);
  cloud->header.frame_id = frame;
  return cloud;
}

std::vector<double> stamps(const std::vector<ScanPlacement::Placement>& placements, bool placed) {
  std::vector<double> result;
  for (const auto& p : placements) {
    if (p.pose.has_value() == placed) result.push_back(p.cloud->header.stamp.toSec());
  }
  return result;
}

TEST(ScanPlacement, ScansWaitForOdometryInArrivalOrder) {
  ScanPlacement placement(settings("topic"), "/r/odom");
  EXPECT_TRUE(placement.wait(scan(1.0)).empty());
  EXPECT_TRUE(placement.wait(scan(1.1)).empty());
  EXPECT_EQ(placement.waiting(), 2U);
  ASSERT_FALSE(placement.addOdometry(odometry(0.9, 0.0)));
  ASSERT_FALSE(placement.addOdometry(odometry(1.05, 1.5)));
  auto released = placement.release();
  ASSERT_EQ(released.size(), 1U) << "the scan at 1.1 waits on";
  EXPECT_NEAR(released[0].pose->translation().x(), 1.0, 1e-9);
  ASSERT_FALSE(placement.addOdometry(odometry(1.2, 3.0)));
  EXPECT_EQ(stamps(placement.release(), true), (std::vector<double>{1.1}));
  EXPECT_EQ(placement.waiting(), 0U);
}

TEST(ScanPlacement, AScanThatCannotBePlacedIsGivenUpWithWhy) {
  ScanPlacement placement(settings("topic"), "/r/odom");
  ASSERT_FALSE(placement.addOdometry(odometry(0.55, 0.0)));
  ASSERT_FALSE(placement.addOdometry(odometry(0.7, 0.0)));
  // A frame whose mount never comes waits until a later scan is placed, then is given up.
  EXPECT_TRUE(placement.wait(scan(0.5, "no_such_frame")).empty());
  auto released = placement.wait(scan(0.6));
  ASSERT_EQ(released.size(), 2U);
  EXPECT_FALSE(released[0].pose);
  EXPECT_EQ(released[0].why.rfind("cannot place it (a later scan was placed first): ", 0), 0U)
      << released[0].why;
  EXPECT_NE(released[0].why.find("no_such_frame"), std::string::npos) << released[0].why;
  EXPECT_TRUE(released[1].pose);
  // Scans waiting for odometry that never comes: the oldest goes when the queue is full.
  for (std::size_t i = 0; i < ScanPlacement::kMaxWaitingScans; ++i) {
    EXPECT_TRUE(placement.wait(scan(2.0 + 0.1 * double(i))).empty());
  }
  released = placement.wait(scan(9.0));
  ASSERT_EQ(released.size(), 1U);
  EXPECT_EQ(released[0].cloud->header.stamp, ros::Time(2.0));
  EXPECT_EQ(released[0].why,
            "cannot place it (waited too long): no odometry at or after its stamp on '/r/odom'");
  // A scan without a frame cannot be placed, whatever arrives.
  released = placement.wait(scan(9.5, ""));
  ASSERT_EQ(released.size(), 1U);
  EXPECT_FALSE(released[0].pose);
  EXPECT_EQ(released[0].why, "cannot place it: it has no frame_id");
  EXPECT_EQ(placement.waiting(), ScanPlacement::kMaxWaitingScans) << "it did not wait";
}

/// A 12 x 8 x 4 m room's walls, floor and ceiling (a point every 0.1 m) seen by a sensor at
/// `x` along the room (its centre at 0), as a cloud in `frame`.
sensor_msgs::PointCloud2::ConstPtr roomScan(double t, double x, const std::string& frame) {
  core::LidarScan room;
  const auto add = [&](double px, double py, double pz) {
    room.points.push_back({float(px - x), float(py), float(pz), 1.0f, 0, 0.0f});
  };
  for (double a = -6.0; a <= 6.0; a += 0.1) {
    for (double b = -4.0; b <= 4.0; b += 0.1) add(a, b, -1.0), add(a, b, 3.0);
    for (double h = -1.0; h <= 3.0; h += 0.1) add(a, -4.0, h), add(a, 4.0, h);
  }
  for (double b = -4.0; b <= 4.0; b += 0.1) {
    for (double h = -1.0; h <= 3.0; h += 0.1) add(-6.0, b, h), add(6.0, b, h);
  }
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  conversions::toPointCloud2(room, frame, cloud.get());
  cloud->header.stamp = ros::Time(t);
  return cloud;
}

TEST(ScanPlacement, FromLidarOdometryAndTheSensorMount) {
  ScanPlacement placement(settings("lidar"), "/r/odom");
  std::string why;
  EXPECT_TRUE(placement.placeable("r/base_link", ros::Time(1.0)));
  EXPECT_FALSE(placement.placeable("r/velodyne", ros::Time(1.0), &why)) << "no mount yet";
  EXPECT_TRUE(placement.wait(roomScan(1.0, 0.0, "r/velodyne")).empty());
  placement.tf().setTransform(transform("r/base_link", "r/velodyne", 0.0, 0.2, 0.5), "test", true);

  // The first scan: the sensor at its mount, base_link at the odometry frame's origin.
  auto released = placement.wait(roomScan(1.1, 0.3, "r/velodyne"));
  ASSERT_EQ(released.size(), 2U);
  ASSERT_TRUE(released[0].pose) << released[0].why;
  EXPECT_TRUE(released[0].pose->isApprox(
      *conversions::toPose(transform("r/base_link", "r/velodyne", 0.0, 0.2, 0.5).transform)));
  ASSERT_TRUE(released[0].odometry_tf);
  EXPECT_EQ(released[0].odometry_tf->header.frame_id, "r/odom");
  EXPECT_EQ(released[0].odometry_tf->child_frame_id, "r/base_link");
  EXPECT_EQ(released[0].odometry_tf->header.stamp, ros::Time(1.0));
  EXPECT_NEAR(released[0].odometry_tf->transform.translation.x, 0.0, 1e-6);

  // The second, 0.3 m further along the room: registered there.
  ASSERT_TRUE(released[1].pose) << released[1].why;
  EXPECT_FALSE(released[1].notice) << released[1].notice->text;
  EXPECT_NEAR(released[1].pose->translation().x(), 0.2 + 0.3, 0.02);
  EXPECT_NEAR(released[1].pose->translation().z(), 0.5, 0.02);
  EXPECT_NEAR(released[1].odometry_tf->transform.translation.x, 0.3, 0.02);
  EXPECT_NEAR(released[1].odometry_tf->transform.translation.y, 0.0, 0.02);
}

}  // namespace
}  // namespace ccir_mapping
