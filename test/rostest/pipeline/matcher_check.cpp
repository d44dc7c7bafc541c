// Checks the two Matchers of matcher.test while the simulated mission replays: every keyframe
// gets a word set under the shipped vocabulary, every teammate word set gets correspondences,
// a word set under another vocabulary or with malformed word ids is refused, and inter-robot loop
// closures are found, many of them agreeing with ground truth, by both robots (robot_b through
// robot_a's kept scans). The small mine is symmetric, so some are aliased (turned by 90 or 180
// degrees); each Backend must still find the true transform to its teammate's frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <std_srvs/SetBool.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "ccir_mapping/Correspondences.h"
#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeFeatures.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/ros/conversions.h"
#include "wait_for.h"

namespace ccir_mapping {
namespace {

using testing::waitFor;

const char* const kRobots[] = {"robot_a", "robot_b"};

/// A robot's true poses (base_link in the world) by stamp, from simulate_team's output.
struct Truth {
  core::Pose3 world_from_odom;
  std::map<core::Stamp, core::Pose3> odom_from_base;

  core::Pose3 at(core::Stamp stamp) const {
    auto it = odom_from_base.lower_bound(stamp);
    if (it == odom_from_base.end()) it = std::prev(it);
    return world_from_odom * it->second;
  }
};

core::Pose3 pose(double x, double y, double z, double qx, double qy, double qz, double qw) {
  core::Pose3 p = core::Pose3::Identity();
  p.translation() << x, y, z;
  p.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  return p;
}

Truth readTruth(const std::string& mission, const YAML::Node& robot) {
  Truth truth;
  const YAML::Node p = robot["initial_pose_in_world"];
  truth.world_from_odom =
      pose(p["x"].as<double>(), p["y"].as<double>(), p["z"].as<double>(), p["qx"].as<double>(),
           p["qy"].as<double>(), p["qz"].as<double>(), p["qw"].as<double>());
  std::ifstream in(mission + "/" + robot["ground_truth"].as<std::string>());
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    double t, x, y, z, qx, qy, qz, qw;
    f >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
    truth.odom_from_base[core::fromSeconds(t)] = pose(x, y, z, qx, qy, qz, qw);
  }
  return truth;
}

struct RobotRecord {
  std::vector<Keyframe::ConstPtr> keyframes;
  std::vector<KeyframeFeatures::ConstPtr> features;
  std::vector<Correspondences::ConstPtr> correspondences;
  std::vector<LoopClosure::ConstPtr> loops;
  double refused_features = 0;    // other vocabulary
  double malformed_features = 0;  // right vocabulary, word ids not a sorted set
};

TEST(Matcher, WordSetsCorrespondencesAndInterRobotLoopClosures) {
  ros::NodeHandle nh;
  const std::string mission = ros::NodeHandle("~").param<std::string>("mission", "");
  ASSERT_FALSE(mission.empty()) << "set ~mission";
  // The Matcher's method (matcher_hgmm.test: hgmm, which compares no descriptors).
  const std::string method = ros::NodeHandle("~").param<std::string>("method", "fabmap");
  const YAML::Node mission_yaml = YAML::LoadFile(mission + "/mission.yaml");
  std::map<std::string, Truth> truth;
  for (const auto& robot : mission_yaml["robots"]) {
    truth[robot["name"].as<std::string>()] = readTruth(mission, robot);
  }
  // The last recorded messages are a scan period before the mission end.
  const ros::Time end(mission_yaml["end_time_s"].as<double>() - 0.5);

  std::map<std::string, RobotRecord> record;
  std::vector<ros::Subscriber> subs;
  for (const std::string robot : kRobots) {
    RobotRecord& r = record[robot];
    subs.push_back(
        nh.subscribe<Keyframe>("/" + robot + "/keyframes", 1000,
                               [&r](const Keyframe::ConstPtr& m) { r.keyframes.push_back(m); }));
    subs.push_back(nh.subscribe<KeyframeFeatures>("/" + robot + "/features", 1000,
                                                  [&r, robot](const KeyframeFeatures::ConstPtr& m) {
                                                    if (m->robot == robot) r.features.push_back(m);
                                                  }));
    subs.push_back(nh.subscribe<Correspondences>(
        "/" + robot + "/correspondences", 1000,
        [&r](const Correspondences::ConstPtr& m) { r.correspondences.push_back(m); }));
    subs.push_back(
        nh.subscribe<LoopClosure>("/" + robot + "/loop_closures", 1000,
                                  [&r](const LoopClosure::ConstPtr& m) { r.loops.push_back(m); }));
  }
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& array) {
        for (const auto& status : array->status) {
          for (const std::string robot : kRobots) {
            if (status.name.find(robot + "/matcher: flow") == std::string::npos) continue;
            for (const auto& entry : status.values) {
              if (entry.key == "dropped features (other vocabulary) messages") {
                record[robot].refused_features = std::stod(entry.value);
              }
              if (entry.key == "dropped features (malformed words) messages") {
                record[robot].malformed_features = std::stod(entry.value);
              }
            }
          }
        }
      });
  std::map<std::string, TeamTransform::ConstPtr> team;  // each robot's latest valid one
  for (const std::string robot : kRobots) {
    subs.push_back(nh.subscribe<TeamTransform>("/" + robot + "/team_transforms", 10,
                                               [&team, robot](const TeamTransform::ConstPtr& m) {
                                                 if (m->valid) team[robot] = m;
                                               }));
  }
  ros::Time now;
  ros::Subscriber clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 10, [&](const rosgraph_msgs::Clock::ConstPtr& m) { now = m->clock; });
  // A word set from a robot with another vocabulary, as robot_a's: robot_b must refuse it.
  ros::Publisher foreign_pub = nh.advertise<KeyframeFeatures>("/robot_a/features", 1, true);
  ASSERT_TRUE(waitFor([&] { return foreign_pub.getNumSubscribers() > 0; }, 60.0))
      << "robot_b's Matcher did not subscribe to robot_a's features";
  auto foreign = boost::make_shared<KeyframeFeatures>();
  foreign->robot = "robot_a";
  foreign->keyframe_id = 100000;
  foreign->vocabulary_hash = "0123456789abcdef";
  foreign->words = {1, 2, 3, 4, 5, 6, 7, 8};
  foreign_pub.publish(foreign);

  // Start the paused replay once every recorded topic is connected: no keyframe is missed.
  ASSERT_TRUE(waitFor(
      [&] {
        return std::all_of(subs.begin(), subs.end(),
                           [](const ros::Subscriber& sub) { return sub.getNumPublishers() > 0; });
      },
      60.0))
      << "the pipelines did not come up";
  std_srvs::SetBool resume;
  resume.request.data = false;
  ASSERT_TRUE(ros::service::waitForService("/player/pause_playback", ros::Duration(60.0)));
  ASSERT_TRUE(ros::service::call("/player/pause_playback", resume));
  // Replayed at half speed (matcher.test): 60 s on any machine; the bound allows five times that.
  ASSERT_TRUE(waitFor([&] { return now >= end; }, 300.0)) << "the mission did not replay";
  // A word set under the right vocabulary but with unsorted, repeated word ids: refused too.
  ASSERT_FALSE(record["robot_b"].features.empty());
  auto malformed = boost::make_shared<KeyframeFeatures>();
  malformed->robot = "robot_a";
  malformed->keyframe_id = 100001;
  malformed->vocabulary_hash = record["robot_b"].features.front()->vocabulary_hash;
  malformed->words = {7, 3, 3, 9};
  foreign_pub.publish(malformed);
  // Done when every keyframe has its word set and every good word set its correspondences (an
  // answer names the word set's keyframe; a new own keyframe's c_k with the word sets before it
  // names one of those too).
  const auto answered = [](const RobotRecord& r) {
    std::set<std::uint64_t> ids;
    for (const auto& c : r.correspondences) ids.insert(c->peer_keyframe_id);
    return ids.size();
  };
  auto settled = [&] {
    const RobotRecord& a = record["robot_a"];
    const RobotRecord& b = record["robot_b"];
    return !a.keyframes.empty() && !b.keyframes.empty() &&
           a.features.size() == a.keyframes.size() + 2 &&  // + the two bad ones
           b.features.size() == b.keyframes.size() && answered(a) == b.features.size() &&
           answered(b) == a.features.size() - 2 && b.refused_features == 1 &&
           b.malformed_features == 1;
  };
  // Generous: a busy machine finishes the last keyframes' matching late, but finishes it.
  EXPECT_TRUE(waitFor(settled, 120.0));

  std::string hash;
  for (const std::string robot : kRobots) {
    const RobotRecord& r = record[robot];
    SCOPED_TRACE(robot);
    ROS_INFO("%s: %zu keyframes, %zu word sets, %zu correspondences, %zu loop closures",
             robot.c_str(), r.keyframes.size(), r.features.size(), r.correspondences.size(),
             r.loops.size());
    EXPECT_GT(r.keyframes.size(), 15U);
    for (const auto& f : r.features) {
      if (f->keyframe_id == foreign->keyframe_id || f->keyframe_id == malformed->keyframe_id) {
        continue;
      }
      if (hash.empty()) hash = f->vocabulary_hash;
      EXPECT_EQ(f->vocabulary_hash, hash);
      EXPECT_FALSE(f->words.empty()) << "keyframe " << f->keyframe_id;
      EXPECT_TRUE(std::is_sorted(f->words.begin(), f->words.end()));
      EXPECT_TRUE(std::adjacent_find(f->words.begin(), f->words.end()) == f->words.end());
      EXPECT_LT(f->words.back(), 500U);  // the shipped 500-word vocabulary
      EXPECT_GE(f->descriptor_count, f->words.size());
    }
    const std::string peer = robot == "robot_a" ? "robot_b" : "robot_a";
    std::size_t nonempty = 0;
    for (const auto& c : r.correspondences) {
      EXPECT_EQ(c->robot, robot);
      EXPECT_EQ(c->peer, peer);
      EXPECT_NE(c->peer_keyframe_id, foreign->keyframe_id) << "the foreign word set was answered";
      EXPECT_NE(c->peer_keyframe_id, malformed->keyframe_id) << "a malformed word set was answered";
      ASSERT_EQ(c->keyframe_ids.size(), c->counts.size());
      EXPECT_TRUE(std::is_sorted(c->counts.rbegin(), c->counts.rend()));
      for (const auto count : c->counts) EXPECT_GE(count, 3U);  // min_correspondences
      nonempty += !c->counts.empty();
    }
    EXPECT_GT(nonempty, r.correspondences.size() / 2) << "most word sets share words here";
  }
  EXPECT_EQ(hash.size(), 16U);
  EXPECT_EQ(record["robot_b"].refused_features, 1.0);
  EXPECT_EQ(record["robot_b"].malformed_features, 1.0);

  // Inter-robot loop closures: relative sensor poses against ground truth.
  std::map<std::pair<std::string, std::uint64_t>, Keyframe::ConstPtr> keyframe_of;
  for (const std::string robot : kRobots) {
    for (const auto& k : record[robot].keyframes) keyframe_of[{robot, k->id}] = k;
  }
  int inter = 0;
  int correct = 0;
  for (const std::string robot : kRobots) {
    int correct_here = 0;
    for (const auto& loop : record[robot].loops) {
      EXPECT_EQ(loop->robot_from, robot);
      if (loop->robot_to == robot) continue;
      ++inter;
      const auto from = keyframe_of.at({loop->robot_from, loop->keyframe_from});
      const auto to = keyframe_of.at({loop->robot_to, loop->keyframe_to});
      // Ground robots on a level floor with the lidar straight above base_link: the relative
      // sensor pose equals the relative base pose.
      auto world_from_sensor = [&](const Keyframe& k) {
        return truth.at(k.robot).at(conversions::toStamp(k.header.stamp));
      };
      const core::Pose3 expected = world_from_sensor(*from).inverse() * world_from_sensor(*to);
      const core::Pose3 error = expected.inverse() * *conversions::toPose(loop->relative_pose);
      const double angle = Eigen::AngleAxisd(error.linear()).angle();
      ROS_INFO("%s %lu <- %s %lu: %d inliers, fitness %.3f, error %.2f m %.1f deg",
               loop->robot_from.c_str(), static_cast<unsigned long>(loop->keyframe_from),
               loop->robot_to.c_str(), static_cast<unsigned long>(loop->keyframe_to),
               static_cast<int>(loop->inliers), loop->fitness_m2, error.translation().norm(),
               angle * 180 / M_PI);
      correct_here += error.translation().norm() < 0.5 && angle < 5 * M_PI / 180;
      EXPECT_EQ(loop->method, method);
      if (method != "hgmm") EXPECT_GE(loop->inliers, 5U);  // the Matcher's min_inliers
    }
    // robot_b follows robot_a: its closures come from robot_a's scans kept before it arrived.
    EXPECT_GE(correct_here, 5) << robot << "'s correct inter-robot loop closures";
    correct += correct_here;
  }
  EXPECT_GE(correct, 10) << "of " << inter << " inter-robot loop closures agree with ground truth";
  // Aliased places pass the descriptors but not the wall overlap and free-space tests.
  EXPECT_GE(10 * correct, 9 * inter) << correct << " of " << inter << " agree with ground truth";

  // Each Backend's EM picks the consistent ones: the teammate's odom frame in its own (the map
  // frames start there; 30 s of odometry drift is well inside the tolerance).
  ASSERT_TRUE(waitFor([&] { return team.size() == 2; }, 90.0))
      << "a Backend announced no valid transform to its teammate";
  for (const std::string robot : kRobots) {
    const std::string peer = robot == "robot_a" ? "robot_b" : "robot_a";
    const TeamTransform& t = *team.at(robot);
    const core::Pose3 expected =
        truth.at(robot).world_from_odom.inverse() * truth.at(peer).world_from_odom;
    const core::Pose3 error = expected.inverse() * *conversions::toPose(t.transform);
    ROS_INFO("%s: team transform from %u of %u closures: error %.2f m %.1f deg", robot.c_str(),
             t.inliers, t.candidates, error.translation().norm(),
             Eigen::AngleAxisd(error.linear()).angle() * 180 / M_PI);
    EXPECT_EQ(t.peer, peer);
    EXPECT_EQ(t.header.frame_id, robot + "/map");
    EXPECT_EQ(t.child_frame_id, peer + "/map");
    EXPECT_LT(error.translation().norm(), 1.0) << robot;
    EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle(), 5 * M_PI / 180) << robot;
  }
}

}  // namespace
}  // namespace ccir_mapping

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "matcher_check");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
