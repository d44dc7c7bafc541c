// Drives one robot's pipeline (launch/robot.launch) with scans and odometry and checks what
// flows out of each nodelet, including how bad input is dropped without stopping the pipeline.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include <octomap/OcTree.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "ccir_mapping/BrokerStats.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/MapStats.h"
#include "ccir_mapping/SharedScan.h"
#include "ccir_mapping/ros/conversions.h"
#include "wait_for.h"

namespace ccir_mapping {
namespace {

using testing::linkedToAllPublishers;
using testing::registeredPublishers;
using testing::waitFor;

constexpr double kSensorHeightM = 0.5;
/// What the pipeline gets to do a step: generous, since CI shares two cores with other jobs
/// (waits return as soon as their condition holds).
constexpr double kWaitS = 30.0;
constexpr double kStepM = 0.5;

class Pipeline : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { instance_ = new Pipeline::State(); }
  static void TearDownTestSuite() { delete instance_; }

  struct State {
    ros::NodeHandle nh;
    // The robot under test and its configured peer (~robot, ~peer), so the same check runs in
    // the root namespace and inside a robot's namespace.
    std::string robot = ros::NodeHandle("~").param<std::string>("robot", "robot_a");
    std::string peer = ros::NodeHandle("~").param<std::string>("peer", "robot_b");
    // ~odom_source "topic": odometry on `odom`; "tf": odom -> base_link broadcast on /tf.
    bool odom_on_tf = ros::NodeHandle("~").param<std::string>("odom_source", "topic") == "tf";
    ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("velodyne_points", 10);
    ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 10);
    tf2_ros::StaticTransformBroadcaster static_tf;
    tf2_ros::TransformBroadcaster tf;
    std::vector<Keyframe::ConstPtr> keyframes;
    std::vector<KeyframeFeatures::ConstPtr> features;
    std::vector<SharedScan::ConstPtr> outbox_scans;
    nav_msgs::Path::ConstPtr trajectory;
    BrokerStats::ConstPtr broker_stats;
    LinkStats::ConstPtr link_stats;
    std::vector<rosgraph_msgs::Log::ConstPtr> log;
    std::map<std::string, std::string> preprocessor_flow;  // its latest diagnostics
    std::vector<ros::Subscriber> subs;
    ros::Subscriber rosout_sub;
    int scan = 0;  // scans published so far; scan i is stamped t0 + 0.1 i
    double t0 = 1000.0;

    State() {
      subs.push_back(nh.subscribe<Keyframe>("keyframes", 100,
                                            [this](const auto& m) { keyframes.push_back(m); }));
      subs.push_back(nh.subscribe<KeyframeFeatures>(
          "outbox/features", 100, [this](const auto& m) { features.push_back(m); }));
      subs.push_back(nh.subscribe<SharedScan>(
          "outbox/scans", 100, [this](const auto& m) { outbox_scans.push_back(m); }));
      subs.push_back(
          nh.subscribe<nav_msgs::Path>("trajectory", 1, [this](const auto& m) { trajectory = m; }));
      subs.push_back(nh.subscribe<BrokerStats>("broker_stats", 1,
                                               [this](const auto& m) { broker_stats = m; }));
      subs.push_back(
          nh.subscribe<LinkStats>("link_stats", 10, [this](const auto& m) { link_stats = m; }));
      rosout_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000,
                                                    [this](const auto& m) { log.push_back(m); });
      subs.push_back(nh.subscribe<diagnostic_msgs::DiagnosticArray>(
          "/diagnostics", 100, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
            for (const auto& status : m->status) {
              const std::string suffix = "preprocessor: flow";
              if (status.hardware_id != robot || status.name.size() < suffix.size() ||
                  status.name.compare(status.name.size() - suffix.size(), suffix.size(), suffix)) {
                continue;
              }
              preprocessor_flow.clear();
              for (const auto& value : status.values) preprocessor_flow[value.key] = value.value;
            }
          }));

      geometry_msgs::TransformStamped mount;
      mount.header.frame_id = robot + "/base_link";
      mount.child_frame_id = robot + "/velodyne";
      mount.transform.translation.z = kSensorHeightM;
      mount.transform.rotation.w = 1.0;
      static_tf.sendTransform(mount);

      EXPECT_TRUE(waitFor(
          [this] {
            return cloud_pub.getNumSubscribers() > 0 &&
                   (odom_on_tf || odom_pub.getNumSubscribers() > 0) &&
                   subs[0].getNumPublishers() > 0 && subs[1].getNumPublishers() > 0 &&
                   subs[2].getNumPublishers() > 0 &&
                   // /rosout is not latched, and some warnings are throttled for a minute:
                   // the first scan must not come before this test hears the manager's log.
                   linkedToAllPublishers(rosout_sub);
          },
          30.0))
          << "the pipeline did not come up (linked to " << rosout_sub.getNumPublishers() << " of "
          << registeredPublishers("/rosout") << " /rosout publishers)";
    }

    ros::Time stamp(int i) const { return ros::Time(t0 + 0.1 * i); }

    static sensor_msgs::PointCloud2 cloud(const std::string& frame, ros::Time stamp) {
      sensor_msgs::PointCloud2 c;
      c.header.frame_id = frame;
      c.header.stamp = stamp;
      sensor_msgs::PointCloud2Modifier modifier(c);
      modifier.setPointCloud2FieldsByString(1, "xyz");
      modifier.resize(1000);
      sensor_msgs::PointCloud2Iterator<float> x(c, "x");
      for (int i = 0; x != x.end(); ++x, ++i) {
        x[0] = static_cast<float>(5.0 * std::cos(i * 0.00628));
        x[1] = static_cast<float>(5.0 * std::sin(i * 0.00628));
        x[2] = 0.0f;
      }
      return c;
    }

    void publishOdometry(ros::Time stamp, double x, std::string frame = "") {
      if (frame.empty()) frame = robot + "/odom";
      auto odom = boost::make_shared<nav_msgs::Odometry>();
      odom->header.stamp = stamp;
      odom->header.frame_id = frame;
      odom->child_frame_id = robot + "/base_link";
      odom->pose.pose.position.x = x;
      odom->pose.pose.orientation.w = 1.0;
      if (!odom_on_tf) return odom_pub.publish(odom);
      geometry_msgs::TransformStamped transform;
      transform.header = odom->header;
      transform.child_frame_id = odom->child_frame_id;
      transform.transform.translation.x = x;
      transform.transform.rotation.w = 1.0;
      tf.sendTransform(transform);
    }

    // Publishes a scan at odometry x (cloud first, odometry after it, as drivers often do).
    void publishScanAt(double x, std::string frame = "") {
      if (frame.empty()) frame = robot + "/velodyne";
      const ros::Time t = stamp(scan++);
      cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(cloud(frame, t)));
      publishOdometry(t, x);
    }

    /// The Preprocessor's count of a flow on diagnostics (0 while it has none).
    long flowCount(const std::string& flow) const {
      const auto it = preprocessor_flow.find(flow + " messages");
      return it == preprocessor_flow.end() ? 0 : std::stol(it->second);
    }

    bool logged(uint8_t level, const std::string& text) const {
      // Only this robot's manager ("/robot_a_manager" or "/robot_a/robot_a_manager").
      for (const auto& entry : log) {
        if (entry->level == level && entry->name.rfind("/" + robot, 0) == 0 &&
            entry->msg.find(text) != std::string::npos) {
          return true;
        }
      }
      return false;
    }
  };
  static State* instance_;
  State& s() { return *instance_; }
};
Pipeline::State* Pipeline::instance_ = nullptr;

TEST_F(Pipeline, KeyframesFollowOdometryDistance) {
  // Keyframe 0 needs the sensor mount from /tf_static: repeat the first pose until it is made.
  int polls = 0;
  ASSERT_TRUE(waitFor(
      [&] {
        if (s().keyframes.empty() && polls++ % 20 == 0) s().publishScanAt(0.0);
        return !s().keyframes.empty();
      },
      30.0))
      << "no first keyframe";
  // Then scans every 0.5 m: every second one is a keyframe (keyframe_distance_m = 1).
  for (int k = 1; k < 10; ++k) {
    s().publishScanAt(k - kStepM);
    s().publishScanAt(k);
    ASSERT_TRUE(
        waitFor([&] { return s().keyframes.size() == static_cast<std::size_t>(k) + 1; }, kWaitS))
        << "keyframe " << k << " did not arrive";
  }
  ASSERT_EQ(s().keyframes.size(), 10u);
  for (std::size_t k = 0; k < s().keyframes.size(); ++k) {
    const Keyframe& kf = *s().keyframes[k];
    EXPECT_EQ(kf.id, k);
    EXPECT_EQ(kf.robot, s().robot);
    EXPECT_EQ(kf.header.frame_id, s().robot + "/velodyne");
    EXPECT_EQ(kf.odom_frame, s().robot + "/odom");
    EXPECT_NEAR(kf.odom_pose.position.x, 1.0 * k, 1e-9);
    EXPECT_NEAR(kf.odom_pose.position.z, kSensorHeightM, 1e-9);  // the sensor mount is applied
    EXPECT_NEAR(kf.travelled_m, k == 0 ? 0.0 : 1.0, 1e-6);
    // The preprocessed scan: a 5 m circle of 1000 points, one per 0.1 m voxel, with normals.
    EXPECT_GT(kf.cloud.width * kf.cloud.height, 250u);
    EXPECT_LT(kf.cloud.width * kf.cloud.height, 400u);
    EXPECT_TRUE(std::any_of(kf.cloud.fields.begin(), kf.cloud.fields.end(),
                            [](const auto& f) { return f.name == "normal_x"; }));
  }
}

TEST_F(Pipeline, FeaturesAndTrajectoryFollowKeyframes) {
  ASSERT_TRUE(waitFor([this] { return s().features.size() >= 10; }, kWaitS));
  for (std::size_t k = 0; k < 10; ++k) {
    EXPECT_EQ(s().features[k]->keyframe_id, k);
    EXPECT_EQ(s().features[k]->robot, s().robot);
  }
  ASSERT_TRUE(
      waitFor([this] { return s().trajectory && s().trajectory->poses.size() == 10; }, kWaitS));
  EXPECT_EQ(s().trajectory->header.frame_id, s().robot + "/map");
  EXPECT_NEAR(s().trajectory->poses.back().pose.position.x, 9.0, 1e-9);
}

TEST_F(Pipeline, FixedRateBrokerSendsEveryNthKeyframe) {
  // pipeline.test sets broker mode fixed_rate with fixed_rate_every_n 2.
  ASSERT_TRUE(waitFor([this] { return s().outbox_scans.size() >= 5; }, kWaitS));
  for (std::size_t n = 0; n < s().outbox_scans.size(); ++n)
    EXPECT_EQ(s().outbox_scans[n]->id, 2 * n);
  // Word sets reach the Broker after their keyframes (the Matcher describes them first): await
  // both counts rather than assume the stats snapshot falls after the last word set.
  ASSERT_TRUE(waitFor(
      [this] {
        return s().broker_stats && s().broker_stats->keyframes == 10 &&
               s().broker_stats->features_sent == 10;
      },
      kWaitS))
      << "keyframes " << (s().broker_stats ? s().broker_stats->keyframes : 0) << ", word sets "
      << (s().broker_stats ? s().broker_stats->features_sent : 0);
  EXPECT_EQ(s().broker_stats->mode, "fixed_rate");
  EXPECT_EQ(s().broker_stats->scans_sent, 5u);
  // In their wire form: a ~300-point keyframe takes a few kB, not the ~15 kB of its cloud.
  EXPECT_GT(s().broker_stats->scan_bytes_sent, 5u * 300u);
  EXPECT_LT(s().broker_stats->scan_bytes_sent, 5u * 6000u);
  EXPECT_EQ(s().broker_stats->kept_scans, 10u);
  ASSERT_EQ(s().broker_stats->peers.size(), 1u);
  EXPECT_EQ(s().broker_stats->peers[0].peer, s().peer);
  EXPECT_EQ(s().broker_stats->peers[0].scans_sent, 5u);
  EXPECT_EQ(s().broker_stats->peers[0].offers_sent, 0u) << "no offers in fixed_rate";
  // What goes out decodes back to the keyframe.
  Keyframe decoded;
  ASSERT_FALSE(conversions::toKeyframe(*s().outbox_scans[1], &decoded));
  EXPECT_EQ(decoded.id, 2u);
  EXPECT_EQ(decoded.robot, s().robot);
  EXPECT_EQ(decoded.cloud.width * decoded.cloud.height,
            s().keyframes[2]->cloud.width * s().keyframes[2]->cloud.height);
}

TEST_F(Pipeline, BridgeReportsItsPeerLink) {
  // The peer never answers (port 9): the 10 features and 5 scans that reached the bridge wait
  // for it (reliable topics), none is dropped.
  ASSERT_TRUE(waitFor(
      [this] {
        return s().link_stats && s().link_stats->queued_control == 10 &&
               s().link_stats->queued_bulk == 5;
      },
      kWaitS));
  EXPECT_TRUE(s().link_stats->drop_reasons.empty());
  EXPECT_EQ(s().link_stats->bytes_sent, 0u);
  EXPECT_EQ(s().link_stats->robot, s().robot);
  EXPECT_EQ(s().link_stats->peer, s().peer);
  EXPECT_FALSE(s().link_stats->connected);
  EXPECT_DOUBLE_EQ(s().link_stats->budget_bytes_per_s, 150000.0);
}

/// Points of `cloud` on the 5 m circles the scans saw from x = 0 .. 9 m, y = `y`, 0.5 m high.
int onCircles(const sensor_msgs::PointCloud2& cloud, double y) {
  int on = 0;
  for (sensor_msgs::PointCloud2ConstIterator<float> p(cloud, "x"); p != p.end(); ++p) {
    for (int k = 0; k < 10; ++k) {
      if (std::abs(std::hypot(p[0] - k, p[1] - y) - 5.0) < 0.2 && std::abs(p[2] - 0.5) < 0.2) {
        ++on;
        break;
      }
    }
  }
  return on;
}

TEST_F(Pipeline, MapperMapsTheKeyframesAndSavesTheMap) {
  MapStats::ConstPtr stats;
  sensor_msgs::PointCloud2::ConstPtr map_cloud;
  auto stats_sub = s().nh.subscribe<MapStats>("map_stats", 10, [&](const auto& m) { stats = m; });
  // The occupied voxels are published only while someone listens.
  auto cloud_sub = s().nh.subscribe<sensor_msgs::PointCloud2>(
      "map_cloud", 1, [&](const auto& m) { map_cloud = m; });
  ASSERT_TRUE(waitFor([&] { return stats && stats->keyframes == 10 && map_cloud; }, kWaitS))
      << "no map statistics for 10 keyframes, or no map cloud";
  EXPECT_EQ(stats->robot, s().robot);
  EXPECT_EQ(stats->header.frame_id, s().robot + "/map");
  EXPECT_DOUBLE_EQ(stats->resolution_m, 0.1);
  // Box of 200 x 200 x 15 m at 0.1 m (voxel centres on both faces): 1 bit per unknown voxel.
  const double box_voxels = 2001.0 * 2001.0 * 151.0;
  // Every known voxel lost some entropy (a single miss takes 0.03 bits, a hit 0.12), none more
  // than its bit.
  const double known_voxels = stats->known_volume_m3 / 1e-3;
  EXPECT_GT(known_voxels, 10000.0);
  EXPECT_GT(box_voxels - stats->entropy_bits, 0.02 * known_voxels);
  EXPECT_LT(box_voxels - stats->entropy_bits, known_voxels);
  EXPECT_EQ(stats->peer_scans, 0u);
  // The 5 m circles seen from x = 0 .. 9 m at 0.5 m height: occupied voxels there, in the map
  // frame.
  EXPECT_EQ(map_cloud->header.frame_id, s().robot + "/map");
  ASSERT_GT(map_cloud->width * map_cloud->height, 100u);
  EXPECT_GT(onCircles(*map_cloud, 0.0), 0.9 * map_cloud->width * map_cloud->height);

  // A teammate's scan with a broken pose is dropped with a warning; the map is unchanged.
  auto broken = boost::make_shared<Keyframe>();
  broken->robot = s().peer;
  broken->odom_pose.position.x = std::numeric_limits<double>::quiet_NaN();
  broken->cloud = State::cloud(s().peer + "/velodyne", s().stamp(0));
  ros::Publisher teammate_scans = s().nh.advertise<Keyframe>("teammate_scans", 10);
  // Until the warning shows (the first publications may precede the connection).
  int polls = 0;
  EXPECT_TRUE(waitFor(
      [&] {
        if (polls++ % 20 == 0) teammate_scans.publish(broken);
        return s().logged(rosgraph_msgs::Log::WARN, "dropping teammate scan");
      },
      kWaitS));
  // One whose wire form does not decode never gets that far: the Broker refuses it.
  auto garbage = boost::make_shared<SharedScan>();
  garbage->robot = s().peer;
  garbage->point_count = 10;
  garbage->points = {1, 2, 3};
  ros::Publisher inbox = s().nh.advertise<SharedScan>("inbox/scans", 10);
  polls = 0;
  EXPECT_TRUE(waitFor(
      [&] {
        if (polls++ % 20 == 0) inbox.publish(garbage);
        return s().logged(rosgraph_msgs::Log::WARN, "dropping scan 0 of '" + s().peer + "'");
      },
      kWaitS));

  // ~save_map writes a binary OctoMap that reads back.
  std_srvs::Trigger save;
  ASSERT_TRUE(ros::service::waitForService("mapper/save_map", 10000));
  ASSERT_TRUE(ros::service::call("mapper/save_map", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  const std::string path = save.response.message.substr(save.response.message.find('/'));
  octomap::OcTree saved(0.1);
  ASSERT_TRUE(saved.readBinary(path)) << path;
  EXPECT_GT(saved.getNumLeafNodes(), 100u);
  std::remove(path.c_str());

  // Optimised poses 1 m away from where the keyframes went in: the map's submaps move there.
  auto moved = boost::make_shared<nav_msgs::Path>(*s().trajectory);
  for (auto& pose : moved->poses) pose.pose.position.y += 1.0;
  ros::Publisher trajectory = s().nh.advertise<nav_msgs::Path>("trajectory", 1);
  polls = 0;
  ASSERT_TRUE(waitFor(
      [&] {
        if (polls++ % 20 == 0) trajectory.publish(moved);
        return stats && stats->submap_moves >= 1;
      },
      kWaitS))
      << "the map did not follow the moved poses";
  EXPECT_EQ(stats->keyframes, 10u);
  const std::uint64_t moves = stats->submap_moves + stats->reintegrations;
  map_cloud.reset();
  ASSERT_TRUE(waitFor(
      [&] { return map_cloud && stats->submap_moves + stats->reintegrations == moves; }, kWaitS));
  EXPECT_GT(onCircles(*map_cloud, 1.0), 0.9 * map_cloud->width * map_cloud->height);
}

TEST_F(Pipeline, BadInputIsDroppedWithAWarningAndThePipelineGoesOn) {
  const std::size_t before = s().keyframes.size();
  const double x = s().keyframes.back()->odom_pose.position.x;

  auto truncated = State::cloud(s().robot + "/velodyne", s().stamp(s().scan++));
  truncated.data.resize(truncated.data.size() - 7);
  s().cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(truncated));
  s().publishOdometry(truncated.header.stamp, x + 5.0);
  s().publishScanAt(x + 10.0, "no_such_frame");
  s().publishOdometry(s().stamp(s().scan++), x + 11.0, "wrong_odom_frame");
  auto empty = State::cloud(s().robot + "/velodyne", s().stamp(s().scan++));
  empty.width = 0;
  empty.row_step = 0;
  empty.data.clear();
  s().cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(empty));  // malformed too
  // Every point NaN: placeable, but nothing to make a keyframe of.
  auto nan_cloud = State::cloud(s().robot + "/velodyne", s().stamp(s().scan++));
  for (sensor_msgs::PointCloud2Iterator<float> p(nan_cloud, "x"); p != p.end(); ++p) {
    p[0] = p[1] = p[2] = std::numeric_limits<float>::quiet_NaN();
  }
  s().cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(nan_cloud));
  s().publishOdometry(nan_cloud.header.stamp, x + 11.5);
  // More points than max_points (5000 in the tests' launch files).
  int max_points = 0;
  ASSERT_TRUE(ros::param::get("preprocessor/max_points", max_points));
  auto huge = State::cloud(s().robot + "/velodyne", s().stamp(s().scan++));
  sensor_msgs::PointCloud2Modifier(huge).resize(max_points + 1);
  s().cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(huge));
  // A stamp going backwards.
  s().cloud_pub.publish(boost::make_shared<sensor_msgs::PointCloud2>(
      State::cloud(s().robot + "/velodyne", s().stamp(s().scan - 3))));
  // A good scan afterwards still makes the next keyframe, and overtakes the unplaceable one.
  s().publishScanAt(x + 12.0);
  ASSERT_TRUE(waitFor([&] { return s().keyframes.size() >= before + 1; }, kWaitS));

  EXPECT_TRUE(
      waitFor([this] { return s().logged(rosgraph_msgs::Log::WARN, "malformed: "); }, kWaitS));
  EXPECT_TRUE(waitFor(
      [this] {
        return s().logged(rosgraph_msgs::Log::WARN, "in frame 'no_such_frame': cannot place it");
      },
      kWaitS));
  for (const char* warning :
       {"malformed: ", "only 0 of 1000 points are finite",
        "1000 of 1000 points are NaN, infinite or zero in an unorganised cloud",
        "stamp not after the previous scan", "lack the field(s) intensity ring time",
        "points, more than max_points"}) {
    EXPECT_TRUE(waitFor([&] { return s().logged(rosgraph_msgs::Log::WARN, warning); }, kWaitS))
        << warning;
  }
  if (!s().odom_on_tf) {  // with tf, odometry in other frames is just another tf edge
    EXPECT_TRUE(waitFor(
        [this] {
          return s().logged(rosgraph_msgs::Log::WARN, "in other frames: 'wrong_odom_frame' ->");
        },
        kWaitS));
  }
  // Each problem counted on diagnostics, by reason.
  std::map<std::string, long> expected = {{"dropped scans (malformed)", 2},
                                          {"dropped scans (cannot place it)", 1},
                                          {"dropped scans (too few points)", 1},
                                          {"dropped scans (too many points)", 1},
                                          {"dropped scans (stamp not increasing)", 1}};
  if (!s().odom_on_tf) expected["dropped odom (in other frames)"] = 1;
  for (const auto& [flow, at_least] : expected) {
    EXPECT_TRUE(waitFor([&] { return s().flowCount(flow) >= at_least; }, 30.0))
        << flow << ": " << s().flowCount(flow);
  }
  // Bad scans made no keyframe: the only new one is the good scan's.
  EXPECT_EQ(s().keyframes.size(), before + 1);
  EXPECT_NEAR(s().keyframes.back()->odom_pose.position.x, x + 12.0, 1e-9);
  EXPECT_EQ(s().keyframes.back()->id, before);
}

// Changes a Preprocessor parameter at run time; returns the value the server reports back.
double reconfigure(const std::string& name, double value) {
  dynamic_reconfigure::Reconfigure srv;
  dynamic_reconfigure::DoubleParameter param;
  param.name = name;
  param.value = value;
  srv.request.config.doubles.push_back(param);
  EXPECT_TRUE(ros::service::call("preprocessor/set_parameters", srv)) << name;
  for (const auto& reported : srv.response.config.doubles) {
    if (reported.name == name) return reported.value;
  }
  ADD_FAILURE() << name << " missing from the reply";
  return std::nan("");
}

// Last: it changes the pipeline's configuration.
TEST_F(Pipeline, ReconfigureAppliesValidChangesAndRefusesInvalidOnes) {
  // max_range_m is within its own bounds but below min_range_m (0.5): refused, value kept.
  EXPECT_DOUBLE_EQ(reconfigure("max_range_m", 0.3), 100.0);
  EXPECT_TRUE(waitFor(
      [this] {
        return s().logged(rosgraph_msgs::Log::ERROR,
                          "reconfigure rejected: max_range_m must be greater than min_range_m");
      },
      kWaitS));

  EXPECT_DOUBLE_EQ(reconfigure("keyframe_distance_m", 2.0), 2.0);
  // Scans every 0.5 m now make a keyframe every fourth scan.
  const std::size_t before = s().keyframes.size();
  const double x = s().keyframes.back()->odom_pose.position.x;
  for (int i = 1; i <= 8; ++i) {
    s().publishScanAt(x + kStepM * i);
    if (i % 4 == 0) {
      ASSERT_TRUE(waitFor([&] { return s().keyframes.size() == before + i / 4; }, kWaitS)) << i;
    }
  }
  EXPECT_EQ(s().keyframes.size(), before + 2);
  EXPECT_NEAR(s().keyframes.back()->odom_pose.position.x, x + 4.0, 1e-9);
  EXPECT_NEAR(s().keyframes.back()->travelled_m, 2.0, 1e-6);
}

}  // namespace
}  // namespace ccir_mapping

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "pipeline_check");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
