// Two robots' keyframes and inter-robot loop closures, most of them false, into robot_a's
// pipeline (launch/robot.launch): half found by robot_a's Matcher, half by robot_b (arriving on
// inbox/loop_closures). The Backend must put the true transform to robot_b's frame on tf and
// announce it as a valid TeamTransform, and pass its own inter-robot closures on to the
// teammates. Unusable closures among them are counted as dropped.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <set>

#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <Eigen/Geometry>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/pose_graph/g2o_io.h"
#include "ccir_mapping/core/testing/synthetic_candidates.h"
#include "ccir_mapping/ros/conversions.h"
#include "wait_for.h"

namespace ccir_mapping {
namespace {

using testing::waitFor;

TEST(TeamTransform, FoundDespiteFalseLoopClosures) {
  ros::NodeHandle nh;
  ros::Publisher keyframes = nh.advertise<Keyframe>("keyframes", 500);
  ros::Publisher peer_keyframes = nh.advertise<Keyframe>("teammate_scans", 500);
  ros::Publisher loops = nh.advertise<LoopClosure>("loop_closures", 500);
  ros::Publisher teammate_loops = nh.advertise<LoopClosure>("inbox/loop_closures", 500);
  int forwarded = 0;
  bool forwarded_only_inter_robot = true;
  ros::Subscriber outbox_sub =
      nh.subscribe<LoopClosure>("outbox/loop_closures", 500, [&](const LoopClosure::ConstPtr& m) {
        ++forwarded;
        forwarded_only_inter_robot &= m->robot_from == "robot_a" && m->robot_to == "robot_b";
      });
  TeamTransform::ConstPtr team;
  ros::Subscriber team_sub = nh.subscribe<TeamTransform>(
      "team_transforms", 10, [&](const TeamTransform::ConstPtr& m) { team = m; });
  double dropped_loops = -1.0;
  double dropped_teammate_loops = -1.0;
  double ignored_teammate_loops = -1.0;
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& array) {
        for (const auto& status : array->status) {
          if (status.name.find("backend: flow") == std::string::npos) continue;
          for (const auto& entry : status.values) {
            if (entry.key == "dropped loop_closures messages")
              dropped_loops = std::stod(entry.value);
            if (entry.key == "dropped inbox/loop_closures messages")
              dropped_teammate_loops = std::stod(entry.value);
            if (entry.key == "ignored inbox/loop_closures (this robot's own) messages")
              ignored_teammate_loops = std::stod(entry.value);
          }
        }
      });
  // Every re-optimisation must reach tf: a transform repeated at a stamp already sent is
  // ignored by tf2 (TF_REPEATED_DATA), so the stamps of each child frame must all differ.
  std::map<std::string, std::vector<double>> tf_stamps;
  std::mutex tf_mutex;
  ros::Subscriber tf_sub =
      nh.subscribe<tf2_msgs::TFMessage>("/tf", 1000, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(tf_mutex);
        for (const auto& t : m->transforms)
          tf_stamps[t.child_frame_id].push_back(t.header.stamp.toSec());
      });
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  ASSERT_TRUE(waitFor(
      [&] {
        return keyframes.getNumSubscribers() > 0 && peer_keyframes.getNumSubscribers() > 0 &&
               loops.getNumSubscribers() > 0 && teammate_loops.getNumSubscribers() > 0 &&
               team_sub.getNumPublishers() > 0 && outbox_sub.getNumPublishers() > 0;
      },
      30.0))
      << "the pipeline did not come up";

  core::testing::SyntheticSpec spec;
  spec.keyframes = 80;  // fewer than the subscribers' queues hold
  spec.inliers = 15;
  spec.outliers = 45;  // 75 % false
  spec.seed = 5;
  const auto s = core::testing::makeSyntheticCandidates(spec);
  const ros::Time t0(100.0);
  auto keyframe = [&](const std::string& robot, std::size_t id, const core::Pose3& pose) {
    auto k = boost::make_shared<Keyframe>();
    k->header.stamp = t0 + ros::Duration(0.1 * id);
    k->header.frame_id = robot + "/velodyne";
    k->robot = robot;
    k->id = id;
    k->odom_frame = robot + "/odom";
    k->odom_pose = conversions::toPoseMsg(pose);
    return k;
  };
  for (std::size_t i = 0; i < s.poses_a.size(); ++i) {
    keyframes.publish(keyframe("robot_a", i, s.poses_a[i]));
    peer_keyframes.publish(keyframe("robot_b", i, s.poses_b[i]));
  }
  // True and false closures interleaved, as place recognition finds them.
  // The random candidates repeat a pair now and then: the Backend counts each pair once.
  std::set<std::pair<int, int>> pairs;
  for (std::size_t k = 0; k < s.candidates.size(); ++k) pairs.insert({s.index_a[k], s.index_b[k]});
  const auto distinct = static_cast<std::uint32_t>(pairs.size());
  std::vector<std::size_t> order(s.candidates.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = (k * 7) % order.size();
  for (const std::size_t k : order) {
    auto loop = boost::make_shared<LoopClosure>();
    loop->header.stamp = t0;
    // Half of them in each direction: the Backend turns them around.
    const bool outgoing = k % 2 == 0;
    loop->robot_from = outgoing ? "robot_a" : "robot_b";
    loop->keyframe_from = static_cast<std::uint64_t>(outgoing ? s.index_a[k] : s.index_b[k]);
    loop->robot_to = outgoing ? "robot_b" : "robot_a";
    loop->keyframe_to = static_cast<std::uint64_t>(outgoing ? s.index_b[k] : s.index_a[k]);
    loop->relative_pose = conversions::toPoseMsg(outgoing ? s.candidates[k].measurement
                                                          : s.candidates[k].measurement.inverse());
    for (int d = 0; d < 6; ++d) loop->covariance[d * 7] = s.candidates[k].covariance(d, d);
    loop->method = "fabmap";
    if (outgoing) {
      loop->odom_pose_from = conversions::toPoseMsg(s.poses_a[s.index_a[k]]);
      loops.publish(loop);
    } else {  // robot_b found it and sent it over
      loop->odom_pose_from = conversions::toPoseMsg(s.poses_b[s.index_b[k]]);
      teammate_loops.publish(loop);
    }
  }
  // Robot_a's own closure coming back is ignored; a teammate's without its keyframe's pose, or
  // naming no robot, cannot be placed.
  auto echo = boost::make_shared<LoopClosure>();
  echo->robot_from = "robot_a";
  echo->robot_to = "robot_b";
  echo->relative_pose.orientation.w = 1.0;
  echo->odom_pose_from.orientation.w = 1.0;
  for (int d = 0; d < 6; ++d) echo->covariance[d * 7] = 0.01;
  teammate_loops.publish(echo);
  auto unplaced = boost::make_shared<LoopClosure>(*echo);
  unplaced->robot_from = "robot_b";
  unplaced->robot_to = "robot_a";
  unplaced->odom_pose_from.orientation.w = 0.0;  // not a rotation
  teammate_loops.publish(unplaced);
  auto nameless = boost::make_shared<LoopClosure>(*echo);
  nameless->robot_from = "";
  nameless->robot_to = "robot_a";
  teammate_loops.publish(nameless);
  // Unusable: a keyframe looped to itself, and a covariance with a NaN (which LLT lets through).
  auto self_loop = boost::make_shared<LoopClosure>();
  self_loop->robot_from = self_loop->robot_to = "robot_a";
  self_loop->keyframe_from = self_loop->keyframe_to = 3;
  self_loop->relative_pose.orientation.w = 1.0;
  for (int d = 0; d < 6; ++d) self_loop->covariance[d * 7] = 0.01;
  loops.publish(self_loop);
  auto nan_covariance = boost::make_shared<LoopClosure>(*self_loop);
  nan_covariance->robot_to = "robot_b";
  nan_covariance->covariance[1] = nan_covariance->covariance[6] = std::nan("");
  loops.publish(nan_covariance);

  // The Backend optimises as soon as a loop closure arrives: the first valid transform may
  // come before the last of the 60 did. Await the one that holds all of them.
  ASSERT_TRUE(waitFor([&] { return team && team->valid && team->candidates == distinct; }, 60.0))
      << "no valid team transform (last: "
      << (team ? std::to_string(team->inliers) + " inliers of " + std::to_string(team->candidates)
               : std::string("none"))
      << ")";
  EXPECT_EQ(team->peer, "robot_b");
  EXPECT_EQ(team->header.frame_id, "robot_a/map");
  EXPECT_EQ(team->child_frame_id, "robot_b/map");
  EXPECT_GE(team->inliers, 12U);
  EXPECT_EQ(team->candidates, distinct);
  EXPECT_GE(distinct, 55U);
  EXPECT_TRUE(waitFor([&] { return dropped_loops == 2.0; }, 10.0))
      << "dropped loop closures reported: " << dropped_loops;
  EXPECT_TRUE(
      waitFor([&] { return dropped_teammate_loops == 2.0 && ignored_teammate_loops == 1.0; }, 10.0))
      << "teammates' closures dropped " << dropped_teammate_loops << ", ignored "
      << ignored_teammate_loops;
  // Robot_a's 30 inter-robot closures went on to the teammates; its own loop and the closure
  // with a NaN covariance did not, nor what came from robot_b.
  EXPECT_TRUE(waitFor([&] { return forwarded == 30; }, 10.0)) << forwarded << " forwarded";
  EXPECT_TRUE(forwarded_only_inter_robot);

  // tf and team_transforms are separate connections: await the tf sent with (or after) the
  // announcement that holds all closures, not an earlier estimate still the latest on tf.
  std::string why;
  geometry_msgs::TransformStamped latest;
  ASSERT_TRUE(waitFor(
      [&] {
        if (!buffer.canTransform("robot_a/map", "robot_b/map", ros::Time(0), &why)) return false;
        latest = buffer.lookupTransform("robot_a/map", "robot_b/map", ros::Time(0));
        return latest.header.stamp >= team->header.stamp;
      },
      10.0))
      << why << " latest tf at " << latest.header.stamp << ", announced at " << team->header.stamp;
  const Eigen::Isometry3d estimate = tf2::transformToEigen(latest);
  // The team graph's transform, fitted to ~13 true closures of 0.1 m / 1 deg noise: a few cm
  // off; a false one would be metres off.
  const Eigen::Isometry3d error = s.truth.inverse() * estimate;
  EXPECT_LT(error.translation().norm(), 0.15);
  EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle() * 180.0 / M_PI, 1.0);

  // ~save_team_graph writes the whole graph, robot_b's keyframes with robot_a's, as g2o (and the
  // trajectories after it: "saved DIR/team_graph.g2o DIR/trajectory.tum DIR/odometry.tum").
  std_srvs::Trigger save;
  ASSERT_TRUE(ros::service::waitForService("backend/save_team_graph", 10000));
  ASSERT_TRUE(ros::service::call("backend/save_team_graph", save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  const std::string& message = save.response.message;
  const auto first = message.find('/');
  const std::string path = message.substr(first, message.find(' ', first) - first);
  const core::pose_graph::PoseGraph saved = core::pose_graph::readG2o(path);
  const auto robot_b_poses = std::count_if(saved.keys.begin(), saved.keys.end(),
                                           [](const auto& key) { return key.robot == 'b'; });
  EXPECT_EQ(robot_b_poses, static_cast<long>(s.poses_b.size()));
  EXPECT_EQ(saved.keys.size(), s.poses_a.size() + s.poses_b.size());
  EXPECT_GE(saved.loopCount(), 12U) << "the closures the EM let in";
  std::remove(path.c_str());

  // One more teammate keyframe: a re-optimisation without a new own keyframe, whose map -> odom
  // and team transform must reach tf as well.
  const auto sent = [&](const std::string& child) {
    std::lock_guard<std::mutex> lock(tf_mutex);
    return tf_stamps[child].size();
  };
  const std::size_t odom_before = sent("robot_a/odom");
  const std::size_t team_before = sent("robot_b/map");
  peer_keyframes.publish(keyframe("robot_b", s.poses_b.size(), s.poses_b.back()));
  EXPECT_TRUE(waitFor(
      [&] { return sent("robot_a/odom") > odom_before && sent("robot_b/map") > team_before; },
      10.0))
      << "no transforms after the re-optimisation";
  std::lock_guard<std::mutex> lock(tf_mutex);
  for (const std::string child : {"robot_a/odom", "robot_b/map"}) {
    auto stamps = tf_stamps[child];
    std::sort(stamps.begin(), stamps.end());
    EXPECT_EQ(std::adjacent_find(stamps.begin(), stamps.end()), stamps.end())
        << child << " sent twice at one stamp: tf2 ignores the second";
  }
}

}  // namespace
}  // namespace ccir_mapping

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "team_transform_check");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
