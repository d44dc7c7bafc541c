// One robot's TeamGraph (own keyframes, teammates' frames from inter-robot loop closures) and the
// worker that runs it on a thread of its own.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <Eigen/Geometry>

#include "ccir_mapping/core/backend/backend_stage.h"
#include "ccir_mapping/core/backend/team_graph.h"
#include "ccir_mapping/core/backend/team_graph_journal.h"
#include "ccir_mapping/core/backend/team_graph_worker.h"
#include "ccir_mapping/core/pose_graph/g2o_io.h"
#include "ccir_mapping/core/testing/synthetic_candidates.h"

namespace ccir_mapping::core::backend {
namespace {

using pose_graph::LoopClosureData;

TEST(TeamGraph, FindsTheTeamTransformFromLoopsInBothDirections) {
  testing::SyntheticSpec spec;
  spec.keyframes = 80;
  spec.inliers = 15;
  spec.outliers = 45;
  spec.seed = 5;
  const auto s = testing::makeSyntheticCandidates(spec);
  // The synthetic poses are exact, and robot b's keyframes hop 2 m around robot a's path: with
  // the default odometry noise their drift would swamp the 10 cm loops.
  BackendParams params;
  params.odometry = {1e-3, 1e-4, 1e-3};
  params.team_graph = false;  // the EM alone (the graph's part: the Corridor tests below)
  TeamGraph graph("robot_a", params);
  for (std::size_t i = 0; i < s.poses_a.size(); ++i) {
    ASSERT_TRUE(graph.addKeyframe(i, fromSeconds(100.0 + i), s.poses_a[i]));
    ASSERT_TRUE(graph.addPeerKeyframe("robot_b", i, s.poses_b[i]));
  }
  EXPECT_FALSE(graph.addKeyframe(3, 0, s.poses_a[3]));  // ids must increase
  int added = 0;
  int true_added = 0;
  for (std::size_t k = 0; k < s.candidates.size(); ++k) {
    LoopClosureData loop;
    const bool outgoing = k % 2 == 0;
    loop.robot_from = outgoing ? "robot_a" : "robot_b";
    loop.keyframe_from = static_cast<KeyframeId>(outgoing ? s.index_a[k] : s.index_b[k]);
    loop.robot_to = outgoing ? "robot_b" : "robot_a";
    loop.keyframe_to = static_cast<KeyframeId>(outgoing ? s.index_b[k] : s.index_a[k]);
    loop.relative = outgoing ? s.candidates[k].measurement : s.candidates[k].measurement.inverse();
    loop.covariance = s.candidates[k].covariance;
    // The same closure found by both robots (the other way round) counts once; the random
    // candidates repeat a pair now and then.
    if (graph.knows(loop)) {
      EXPECT_FALSE(graph.addLoopClosure(loop));
      continue;
    }
    ASSERT_TRUE(graph.addLoopClosure(loop));
    ++added;
    true_added += s.inlier[k];
  }
  ASSERT_GE(true_added, 12);
  LoopClosureData again;
  again.robot_from = "robot_b";
  again.keyframe_from = static_cast<KeyframeId>(s.index_b[0]);
  again.robot_to = "robot_a";
  again.keyframe_to = static_cast<KeyframeId>(s.index_a[0]);
  EXPECT_TRUE(graph.knows(again));
  EXPECT_FALSE(graph.addLoopClosure(again));
  again.keyframe_to += 1000;
  EXPECT_FALSE(graph.knows(again));

  const BackendSnapshot snapshot = graph.optimize();
  ASSERT_EQ(snapshot.poses.size(), 80U);
  EXPECT_TRUE(snapshot.poses.back().isApprox(s.poses_a.back(), 1e-6));  // no intra loops
  ASSERT_EQ(snapshot.team.size(), 1U);
  const auto& estimate = snapshot.team.front();
  EXPECT_EQ(estimate.candidates, added);
  ASSERT_TRUE(estimate.alignment.found) << estimate.alignment.reason;
  const Pose3 error = s.truth.inverse() * estimate.alignment.transform;
  EXPECT_LT(error.translation().norm(), 0.1);
  EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle() * 180 / M_PI, 1.0);
  const auto covariance = graph.covariances({10});
  ASSERT_TRUE(covariance);
  EXPECT_GT(covariance->front().trace(), 0.0);
  // What rviz draws: one line per inlier, from own keyframe to the teammate's placed with the
  // transform, where it truly is.
  ASSERT_EQ(snapshot.loop_lines.size(), static_cast<std::size_t>(estimate.alignment.inlier_count));
  for (const auto& line : snapshot.loop_lines) {
    EXPECT_TRUE(line.inter_robot && line.accepted);
    EXPECT_LT((line.from - line.to).norm(), 10.0);
  }
}

TEST(TeamGraph, LoopsSeenAfterTheTeammatesDriftAgreeAndTheLeastDriftedWeighMost) {
  // Both robots drive one 60 m corridor; robot b's odometry turns 0.1 deg too far per metre
  // (6 deg and 3.6 m off at the end). Every place is closed exactly (1 cm, 0.06 deg): without
  // the drift in the candidates' covariances only the first few loops would agree.
  const Pose3 truth =
      Pose3(Eigen::Translation3d(5, 2, 0)) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  TeamGraph graph("robot_a", BackendParams{});
  std::vector<Pose3> odom_b;
  for (int i = 0; i < 60; ++i) {
    const Pose3 a(Eigen::Translation3d(i, 0, 0));
    ASSERT_TRUE(graph.addKeyframe(i, fromSeconds(i), a));
    const Pose3 true_b = truth.inverse() * a;
    odom_b.push_back(
        i == 0
            ? true_b
            : odom_b.back() * Eigen::AngleAxisd(0.1 * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                  (truth.inverse() * Pose3(Eigen::Translation3d(i - 1, 0, 0))).inverse() * true_b);
    LoopClosureData loop;
    loop.robot_from = "robot_a";
    loop.keyframe_from = i;
    loop.robot_to = "robot_b";
    loop.keyframe_to = 100 + i;
    loop.relative = a.inverse() * truth * true_b;
    loop.covariance = Matrix6::Identity() * 1e-6;
    ASSERT_TRUE(graph.addLoopClosure(loop));
  }
  for (int i = 59; i >= 0; --i) ASSERT_TRUE(graph.addPeerKeyframe("robot_b", 100 + i, odom_b[i]));
  const auto end_drift =
      (truth.inverse() * Pose3(Eigen::Translation3d(59, 0, 0))).inverse() * odom_b.back();
  ASSERT_GT(end_drift.translation().norm(), 3.0);

  const BackendSnapshot snapshot = graph.optimize();
  ASSERT_EQ(snapshot.team.size(), 1U);
  const auto& alignment = snapshot.team.front().alignment;
  ASSERT_TRUE(alignment.found) << alignment.reason;
  EXPECT_GE(alignment.inlier_count, 50);
  const Pose3 error = truth.inverse() * alignment.transform;
  EXPECT_LT(error.translation().norm(), 0.3);
  EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle() * 180 / M_PI, 1.0);
}

// Two robots drive one 60 m corridor side by side, 0.5 m apart; robot b's frame is `truth` in
// robot a's, and b's odometry turns 0.1 deg too far per metre (3 m off at the far end):
//
//   a:  0---1---2--- ... ---14--- ... ---45--- ... ---59     exact odometry
//       :   :   :           :            :            :
//   b:  100-101-102- ... ---114-- ... ---145-- ... ---159    drifting odometry
//       \____ first meeting ____/       \__ second meeting _/
//
// Each meeting closes every place it passes (1 cm, 0.06 deg).
class Corridor : public ::testing::Test {
 protected:
  static constexpr int kLength = 60;
  const Pose3 truth =
      Pose3(Eigen::Translation3d(5, 2, 0)) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());

  Corridor() {
    for (int i = 0; i < kLength; ++i) {
      own_.push_back(Pose3(Eigen::Translation3d(i, 0, 0)));
      true_b_.push_back(Pose3(Eigen::Translation3d(i, 0.5, 0)));  // in a's frame
      const Pose3 b = truth.inverse() * true_b_.back();
      odom_b_.push_back(i == 0 ? b
                               : odom_b_.back() *
                                     Eigen::AngleAxisd(0.1 * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                                     (truth.inverse() * true_b_[i - 1]).inverse() * b);
    }
  }

  void addKeyframes(TeamGraph& graph, int first, int last) const {
    for (int i = first; i <= last; ++i) {
      ASSERT_TRUE(graph.addKeyframe(i, fromSeconds(i), own_[i]));
      ASSERT_TRUE(graph.addPeerKeyframe("robot_b", 100 + i, odom_b_[i]));
    }
  }
  /// a's keyframe i sees b's keyframe j (truly where the measurement says when j == i).
  LoopClosureData loop(int i, int j, const Pose3& offset = Pose3::Identity()) const {
    LoopClosureData l;
    l.robot_from = "robot_a";
    l.keyframe_from = i;
    l.robot_to = "robot_b";
    l.keyframe_to = 100 + j;
    l.relative = own_[i].inverse() * true_b_[i] * offset;
    l.covariance = Matrix6::Identity() * 1e-4;
    return l;
  }
  void meet(TeamGraph& graph, int first, int last) const {
    for (int i = first; i <= last; ++i) ASSERT_TRUE(graph.addLoopClosure(loop(i, i)));
  }
  /// Mean distance of b's keyframes `first`..`last` in the graph from where they truly are.
  double errorOf(const BackendSnapshot& snapshot, int first, int last) const {
    double sum = 0.0;
    int n = 0;
    for (const auto& peer : snapshot.peer_keyframes) {
      for (std::size_t k = 0; k < peer.ids.size(); ++k) {
        const int i = static_cast<int>(peer.ids[k]) - 100;
        if (i < first || i > last) continue;
        sum += (peer.poses[k].translation() - true_b_[i].translation()).norm();
        ++n;
      }
    }
    EXPECT_EQ(n, last - first + 1) << "b's keyframes in the graph";
    return n ? sum / n : 1e9;
  }
  static const TeamEstimate& estimateOf(const BackendSnapshot& snapshot) {
    EXPECT_EQ(snapshot.team.size(), 1U);
    return snapshot.team.front();
  }
  double transformError(const BackendSnapshot& snapshot) const {
    return (truth.inverse() * estimateOf(snapshot).alignment.transform).translation().norm();
  }

  std::vector<Pose3> own_, true_b_, odom_b_;
};

TEST_F(Corridor, AfterTheSecondMeetingTheTeammatesFarKeyframesMoveTowardsTheTruth) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  const BackendSnapshot first = graph.optimize();
  ASSERT_TRUE(estimateOf(first).in_graph) << estimateOf(first).alignment.reason;
  ASSERT_EQ(first.peer_keyframes.size(), 1U);
  EXPECT_EQ(first.peer_keyframes[0].robot, "robot_b");
  EXPECT_EQ(first.loops.inter, 15);
  EXPECT_EQ(first.loops.inter_rejected, 0);
  ASSERT_EQ(first.notices.size(), 1U);
  EXPECT_EQ(first.notices[0].text, "robot_b joins the graph: 15 of 15 closures agree");
  const double far_before = errorOf(first, 45, 59);
  EXPECT_GT(far_before, 1.0) << "placed by its drifting odometry";
  EXPECT_LT(errorOf(first, 0, 14), 0.1);

  meet(graph, 45, 59);
  const BackendSnapshot second = graph.optimize();
  EXPECT_EQ(second.loops.inter, 30);
  EXPECT_EQ(second.loops.inter_rejected, 0) << "true closures seen after drift";
  const double far_after = errorOf(second, 45, 59);
  // Towards the truth, not onto it: robot a's own odometry is as uncertain as b's to the graph,
  // so the two share b's drift (a's far end moves too); relative to a, b is where it should be
  // (the loop lines below).
  EXPECT_LT(far_after, 0.75 * far_before);
  EXPECT_LT(errorOf(second, 15, 44), errorOf(first, 15, 44)) << "between the meetings too";
  // The graph's transform (its gauge of b's part) stays where b's frame truly is, and the own
  // trajectory stays consistent with it.
  EXPECT_LT(transformError(second), 0.1);
  EXPECT_NEAR(second.poses.back().translation().x(), kLength - 1, 0.05);
  EXPECT_GT(second.poses.back().translation().y(), 0.5) << "a shares b's drift";
  for (const auto& line : second.loop_lines) {  // the two trajectories agree with each other
    EXPECT_TRUE(line.inter_robot && line.accepted);
    EXPECT_NEAR((line.from - line.to).norm(), 0.5, 0.05);
  }
}

TEST_F(Corridor, AFalseClosureAmongTrueOnesIsSwitchedOff) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  // a's keyframe 30 "sees" b's keyframe 22 where b's keyframe 30 is (the mine repeats).
  ASSERT_TRUE(graph.addLoopClosure(loop(30, 22)));
  const BackendSnapshot snapshot = graph.optimize();
  ASSERT_TRUE(estimateOf(snapshot).in_graph);
  EXPECT_EQ(snapshot.loops.inter, 16);
  EXPECT_EQ(snapshot.loops.inter_rejected, 1);
  int rejected = 0;
  for (const auto& line : snapshot.loop_lines) {
    if (line.accepted) continue;
    ++rejected;
    EXPECT_TRUE(line.inter_robot);
    EXPECT_NEAR(line.from.x(), 30.0, 0.1) << "the false one";
  }
  EXPECT_EQ(rejected, 1);
  EXPECT_LT(errorOf(snapshot, 15, 30), 1.0) << "b's keyframe 22 not pulled 8 m along";
}

TEST_F(Corridor, TheWholeTeamGraphIsExportedToG2oWithRobotKeyedIdsAndSwitchValues) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  ASSERT_TRUE(graph.addLoopClosure(loop(30, 22)));  // false: the gate keeps it out
  graph.optimize();
  std::vector<double> switches;
  std::vector<std::string> robots;
  const pose_graph::PoseGraph exported = graph.exportGraph(&switches, &robots);
  EXPECT_EQ(robots, (std::vector<std::string>{"robot_a", "robot_b"}));
  ASSERT_EQ(exported.poses.size(), 2U * kLength);
  EXPECT_EQ(exported.keys[0].id(), (std::uint64_t('a') << 56));
  EXPECT_EQ(exported.keys[kLength].robot, 'b');
  EXPECT_EQ(exported.keys[kLength].index, 100U);
  EXPECT_LT((exported.poses[kLength + 20].translation() - true_b_[20].translation()).norm(), 0.2);
  ASSERT_EQ(switches.size(), exported.edges.size());
  ASSERT_EQ(exported.loopCount(), 15U) << "the true closures; the false one never entered";
  for (std::size_t k = 0; k < exported.edges.size(); ++k) {
    if (exported.edges[k].loop) EXPECT_GT(switches[k], 0.9) << k;
  }

  const std::string path = ::testing::TempDir() + "team_graph_export.g2o";
  pose_graph::writeG2o(exported, path, switches);
  const pose_graph::PoseGraph back = pose_graph::readG2o(path);
  ASSERT_EQ(back.keys.size(), exported.keys.size());
  for (std::size_t i = 0; i < back.keys.size(); ++i) {
    EXPECT_EQ(back.keys[i].id(), exported.keys[i].id());
    EXPECT_TRUE(back.poses[i].isApprox(exported.poses[i], 1e-9));
  }
  EXPECT_EQ(back.loopCount(), 15U) << "the switchable edges";
  EXPECT_EQ(back.edges.size() - back.loopCount(), 2U * (kLength - 1)) << "both odometry chains";
  std::ifstream file(path);
  int switch_lines = 0;
  for (std::string line; std::getline(file, line);)
    switch_lines += line.rfind("VERTEX_SWITCH", 0) == 0;
  EXPECT_EQ(switch_lines, 15);
  std::remove(path.c_str());
}

TEST_F(Corridor, SaveWritesTheGraphAndBothTrajectoriesIntoAFolderItCreates) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  graph.optimize();
  ASSERT_TRUE(
      graph.addKeyframe(kLength, fromSeconds(kLength),
                        own_.back() * Pose3(Eigen::Translation3d(1, 0, 0))));  // not optimised
  const std::string dir = ::testing::TempDir() + "team_graph_save/robot_a";
  std::filesystem::remove_all(dir);
  const auto files = graph.save(dir);
  ASSERT_EQ(files, (std::vector<std::string>{dir + "/team_graph.g2o", dir + "/trajectory.tum",
                                             dir + "/odometry.tum"}));
  EXPECT_EQ(pose_graph::readG2o(files[0]).poses.size(), 2U * kLength);
  const TumTrajectory trajectory = readTumTrajectory(files[1]);
  const TumTrajectory odometry = readTumTrajectory(files[2]);
  ASSERT_EQ(trajectory.stamps.size(), kLength + 1U) << "the newest continued by odometry";
  EXPECT_EQ(trajectory.stamps, graph.trajectory().stamps);
  EXPECT_EQ(odometry.stamps, trajectory.stamps);
  EXPECT_EQ(trajectory.stamps.back(), fromSeconds(kLength));
  for (std::size_t i = 0; i < trajectory.poses.size(); ++i) {
    EXPECT_TRUE(trajectory.poses[i].isApprox(graph.trajectory().poses[i], 1e-6)) << i;
    EXPECT_TRUE(odometry.poses[i].isApprox(graph.odometry().poses[i], 1e-6)) << i;
  }
  EXPECT_TRUE(odometry.poses[20].isApprox(own_[20], 1e-6));
  EXPECT_TRUE(trajectory.poses[kLength].isApprox(
      trajectory.poses[kLength - 1] * Pose3(Eigen::Translation3d(1, 0, 0)), 1e-6));

  const std::string blocked = ::testing::TempDir() + "team_graph_save/a_file";
  std::ofstream(blocked) << "not a folder";
  EXPECT_THROW(graph.save(blocked + "/robot_a"), std::runtime_error);
  std::filesystem::remove_all(::testing::TempDir() + "team_graph_save");
}

TEST_F(Corridor, BetweenFullEmRunsNewClosuresAreGatedByTheTransformFoundBefore) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 24);
  ASSERT_TRUE(estimateOf(graph.optimize()).in_graph);
  // One true and one false closure: less than 10 % more, so the transform is re-checked (one
  // E-step), not searched again.
  ASSERT_TRUE(graph.addLoopClosure(loop(25, 25)));
  ASSERT_TRUE(graph.addLoopClosure(loop(40, 32)));
  const BackendSnapshot snapshot = graph.optimize();
  EXPECT_EQ(estimateOf(snapshot).alignment.log_likelihood_trace.size(), 1U);
  EXPECT_EQ(estimateOf(snapshot).alignment.inlier_count, 26);
  EXPECT_EQ(snapshot.loops.inter, 27);
  EXPECT_EQ(snapshot.loops.inter_rejected, 1) << "the false one";
  // Three more: 10 % more than at the last full EM, which runs again.
  for (int i = 26; i < 29; ++i) ASSERT_TRUE(graph.addLoopClosure(loop(i, i)));
  EXPECT_GT(estimateOf(graph.optimize()).alignment.log_likelihood_trace.size(), 1U);
}

TEST_F(Corridor, OneFalseClosureAloneNeverMakesATeamTransform) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  ASSERT_TRUE(graph.addLoopClosure(loop(30, 22)));
  const BackendSnapshot snapshot = graph.optimize();
  EXPECT_FALSE(estimateOf(snapshot).alignment.found);
  EXPECT_FALSE(estimateOf(snapshot).in_graph);
  EXPECT_TRUE(snapshot.peer_keyframes.empty());
  EXPECT_EQ(snapshot.loops.inter, 0);
  EXPECT_TRUE(snapshot.poses.back().isApprox(own_.back(), 1e-9)) << "own graph untouched";
}

TEST_F(Corridor, TeammatesKeyframesWaitForTheTransformAndArePlacedOnceItIsFound) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 5);  // 6 closures: fewer than min_team_inliers
  const BackendSnapshot waiting = graph.optimize();
  EXPECT_FALSE(estimateOf(waiting).alignment.found);
  EXPECT_TRUE(waiting.peer_keyframes.empty());
  meet(graph, 6, 14);
  const BackendSnapshot placed = graph.optimize();
  ASSERT_TRUE(estimateOf(placed).in_graph);
  EXPECT_LT(errorOf(placed, 0, 14), 0.1) << "placed and optimised in the same optimize()";
  EXPECT_EQ(placed.peer_keyframes[0].ids.size(), static_cast<std::size_t>(kLength));
}

TEST_F(Corridor, ALaterDisagreeingEmTransformIsLoggedAndTheGraphKeptWhileItsSwitchesAgreeAsWell) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  ASSERT_TRUE(estimateOf(graph.optimize()).in_graph);
  // Then 18 closures that agree with each other and not with the truth: where the mine repeats
  // every 8 m, a's keyframes 30..47 "see" b's 22..39. The EM now prefers them (18 inliers to
  // 15, its margin of 3); the graph's switches keep the 15 true ones, within that margin.
  for (int i = 30; i < 48; ++i) ASSERT_TRUE(graph.addLoopClosure(loop(i, i - 8)));
  // The EM judges them at once, the graph at its next solve; the two are compared after it.
  EXPECT_TRUE(graph.optimize().notices.empty()) << "the graph has not judged them yet";
  meet(graph, 15, 15);  // something new to solve
  const BackendSnapshot snapshot = graph.optimize();
  const TeamEstimate& estimate = estimateOf(snapshot);
  ASSERT_EQ(snapshot.notices.size(), 1U);
  EXPECT_EQ(snapshot.notices[0].kind, "team disagreement");
  EXPECT_NE(snapshot.notices[0].text.find(
                "keeping the graph's: its switches accept 15 closures, the EM 18 of them"),
            std::string::npos)
      << snapshot.notices[0].text;
  EXPECT_TRUE(estimate.in_graph);
  EXPECT_LT(transformError(snapshot), 0.1) << "the graph's transform, not the EM's";
  EXPECT_EQ(snapshot.loops.inter_rejected, 19) << "the 18, and the new true one the EM gates out";
}

TEST_F(Corridor, ADisagreeingEmTransformReplacesAGraphWhoseSwitchesRejectedItsClosures) {
  BackendParams params;
  params.min_team_inliers = 5;
  params.team_inlier_margin = 1;
  TeamGraph graph("robot_a", params);
  addKeyframes(graph, 0, kLength - 1);
  // First 6 false closures (b's keyframes 8 m along): b joins where it is not.
  for (int i = 20; i < 26; ++i) ASSERT_TRUE(graph.addLoopClosure(loop(i, i - 8)));
  ASSERT_TRUE(estimateOf(graph.optimize()).in_graph);
  // Then 30 true ones: the EM moves to the truth; the graph, 8 m off, accepts only the 6.
  meet(graph, 0, 28);
  EXPECT_TRUE(graph.optimize().notices.empty()) << "the graph has not judged them yet";
  meet(graph, 29, 29);
  const BackendSnapshot snapshot = graph.optimize();
  ASSERT_EQ(snapshot.notices.size(), 1U);
  EXPECT_EQ(snapshot.notices[0].kind, "team disagreement");
  EXPECT_NE(snapshot.notices[0].text.find("the graph accepts only 6 closures, the EM 29 of them: "
                                          "robot_b placed again with the EM transform"),
            std::string::npos)
      << snapshot.notices[0].text;
  EXPECT_TRUE(estimateOf(snapshot).in_graph);
  EXPECT_LT(transformError(snapshot), 0.1) << "re-optimised from the EM's transform";
  EXPECT_EQ(snapshot.loops.inter_rejected, 6);
}

TEST_F(Corridor, WithoutTheTeamGraphTheTeammateStaysOutAndIsPlacedByTheEmAlone) {
  BackendParams params;
  params.team_graph = false;
  TeamGraph graph("robot_a", params);
  addKeyframes(graph, 0, kLength - 1);
  meet(graph, 0, 14);
  const BackendSnapshot snapshot = graph.optimize();
  EXPECT_TRUE(estimateOf(snapshot).alignment.found);
  EXPECT_FALSE(estimateOf(snapshot).in_graph);
  EXPECT_TRUE(snapshot.peer_keyframes.empty());
  EXPECT_EQ(snapshot.loops.inter, 0);
  EXPECT_EQ(snapshot.loop_lines.size(), 15U) << "the EM's inliers";
}

// Robot a meets robots b and c where the three start; b and c then drive on together, 0.5 m
// on either side of a's line, their odometries drifting apart (b turns 0.1 deg per metre too far
// left, c too far right), and meet each other again at the far end: closures robot b found and
// shared with its teammates. In robot a's graph they hold b and c together:
//
//   b:  100-101- ... -114--- ... ---145- ... -159      turns 0.1 deg/m too far left
//       :    :         :              :          :
//   a:  0----1-- ... --14                              exact odometry
//       :    :         :              :          :
//   c:  200-201- ... -214--- ... ---245- ... -259      turns 0.1 deg/m too far right
//       \_ a meets b, a meets c _/    \_ b meets c _/
//
// Each closure is exact, with 1 cm, 0.06 deg covariance.
class ThreeRobots : public ::testing::Test {
 protected:
  static constexpr int kLength = 60;
  static constexpr int kFar = 45;  // where b meets c again

  ThreeRobots() {
    frame_["robot_b"] =
        Pose3(Eigen::Translation3d(5, 2, 0)) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
    frame_["robot_c"] =
        Pose3(Eigen::Translation3d(-4, 1, 0)) * Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitZ());
    for (int i = 0; i < kLength; ++i) {
      truth_["robot_a"].push_back(Pose3(Eigen::Translation3d(i, 0, 0)));
      truth_["robot_b"].push_back(Pose3(Eigen::Translation3d(i, 0.5, 0)));  // in a's frame
      truth_["robot_c"].push_back(Pose3(Eigen::Translation3d(i, -0.5, 0)));
      for (const auto& [robot, turn_deg] :
           {std::pair{"robot_b", 0.1}, std::pair{"robot_c", -0.1}}) {
        const auto& t = truth_[robot];
        const Pose3 in_own = frame_[robot].inverse() * t[i];
        auto& odom = odom_[robot];
        odom.push_back(
            i == 0
                ? in_own
                : odom.back() * Eigen::AngleAxisd(turn_deg * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                      (frame_[robot].inverse() * t[i - 1]).inverse() * in_own);
      }
    }
  }
  static KeyframeId idOf(const std::string& robot, int i) {
    return static_cast<KeyframeId>(robot == "robot_a" ? i : robot == "robot_b" ? 100 + i : 200 + i);
  }
  void addKeyframes(TeamGraph& graph) const {
    for (int i = 0; i < kLength; ++i) {
      ASSERT_TRUE(graph.addKeyframe(idOf("robot_a", i), fromSeconds(i), truth_.at("robot_a")[i]));
      for (const char* peer : {"robot_b", "robot_c"}) {
        ASSERT_TRUE(graph.addPeerKeyframe(peer, idOf(peer, i), odom_.at(peer)[i]));
      }
    }
  }
  /// `from`'s keyframe i sees `to`'s keyframe j (truly where the measurement says when i == j).
  LoopClosureData loop(const std::string& from, const std::string& to, int i, int j) const {
    LoopClosureData l;
    l.robot_from = from;
    l.keyframe_from = idOf(from, i);
    l.robot_to = to;
    l.keyframe_to = idOf(to, j);
    l.relative = truth_.at(from)[i].inverse() * truth_.at(to)[i];
    l.covariance = Matrix6::Identity() * 1e-4;
    return l;
  }
  void meet(TeamGraph& graph, const std::string& from, const std::string& to, int first,
            int last) const {
    for (int i = first; i <= last; ++i) ASSERT_TRUE(graph.addLoopClosure(loop(from, to, i, i)));
  }
  /// Mean distance between b's and c's keyframes `first`..`last` in the graph (truly 1 m).
  static double gapOf(const BackendSnapshot& snapshot, int first, int last) {
    std::map<KeyframeId, Pose3> poses;
    for (const auto& peer : snapshot.peer_keyframes) {
      for (std::size_t k = 0; k < peer.ids.size(); ++k) poses[peer.ids[k]] = peer.poses[k];
    }
    double sum = 0.0;
    for (int i = first; i <= last; ++i) {
      EXPECT_TRUE(poses.count(idOf("robot_b", i)) && poses.count(idOf("robot_c", i)));
      sum += (poses[idOf("robot_b", i)].translation() - poses[idOf("robot_c", i)].translation())
                 .norm();
    }
    return sum / (last - first + 1);
  }

  std::map<std::string, Pose3> frame_;                      // teammates' frames in a's
  std::map<std::string, std::vector<Pose3>> truth_, odom_;  // in a's frame; in their own
};

TEST_F(ThreeRobots, ClosuresBetweenTwoTeammatesHoldThemTogetherOnceBothAreInTheGraph) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph);
  meet(graph, "robot_a", "robot_b", 0, 14);
  meet(graph, "robot_b", "robot_c", kFar, kLength - 1);  // found by b, shared
  const BackendSnapshot b_only = graph.optimize();
  ASSERT_EQ(b_only.peer_keyframes.size(), 1U) << "c has no transform yet";
  EXPECT_EQ(b_only.loops.inter, 15) << "b's closures with c wait for c";

  meet(graph, "robot_c", "robot_a", 0, 14);  // found by c: the other direction
  const BackendSnapshot both = graph.optimize();
  ASSERT_EQ(both.peer_keyframes.size(), 2U);
  EXPECT_EQ(both.loops.inter, 45);
  EXPECT_EQ(both.loops.inter_rejected, 0);
  EXPECT_NEAR(gapOf(both, kFar, kLength - 1), 1.0, 0.05) << "b and c where they met";
  EXPECT_NEAR(gapOf(both, 0, 14), 1.0, 0.05);

  // Without the closures between b and c, their drifts part them at the far end.
  TeamGraph apart("robot_a", BackendParams{});
  addKeyframes(apart);
  meet(apart, "robot_a", "robot_b", 0, 14);
  meet(apart, "robot_c", "robot_a", 0, 14);
  EXPECT_GT(gapOf(apart.optimize(), kFar, kLength - 1), 2.0);
}

TEST_F(ThreeRobots, AFalseClosureBetweenTwoTeammatesIsGatedOut) {
  TeamGraph graph("robot_a", BackendParams{});
  addKeyframes(graph);
  meet(graph, "robot_a", "robot_b", 0, 14);
  meet(graph, "robot_c", "robot_a", 0, 14);
  meet(graph, "robot_b", "robot_c", kFar, kLength - 1);
  // b's keyframe 30 "sees" c's keyframe 22 where c's keyframe 30 is (the mine repeats).
  ASSERT_TRUE(graph.addLoopClosure(loop("robot_b", "robot_c", 30, 22)));
  const BackendSnapshot snapshot = graph.optimize();
  EXPECT_EQ(snapshot.loops.inter, 46);
  EXPECT_EQ(snapshot.loops.inter_rejected, 1);
  EXPECT_NEAR(gapOf(snapshot, kFar, kLength - 1), 1.0, 0.05);
  EXPECT_NEAR(gapOf(snapshot, 22, 30), 1.0, 0.5) << "c's keyframe 22 not pulled 8 m along";
}

TEST_F(ThreeRobots, ATeammatesOwnClosureIsRefused) {
  TeamGraph graph("robot_a", BackendParams{});
  EXPECT_FALSE(graph.addLoopClosure(loop("robot_b", "robot_b", 40, 10))) << "never shared";
  EXPECT_TRUE(graph.addLoopClosure(loop("robot_b", "robot_c", 40, 40)));
  EXPECT_FALSE(graph.addLoopClosure(loop("robot_c", "robot_b", 40, 40))) << "counted once";
}

// A robot killed after the first meeting: the inputs its journal kept rebuild the same graph in a
// new worker, which then carries on with new keyframes.
TEST_F(Corridor, AResumedWorkerRebuildsTheGraphTheJournalKeptAndCarriesOn) {
  using Worker = TeamGraphWorker;
  const std::string dir =
      ::testing::TempDir() + "team_graph_journal_" + std::to_string(::getpid()) + "/robot_a";
  std::filesystem::remove_all(dir);
  std::vector<BackendSnapshot> before, after;
  Worker::Hooks hooks;
  std::vector<std::string> unjournaled;
  hooks.unjournaled = [&](const std::string& why) { unjournaled.push_back(why); };
  {
    hooks.optimized = [&](const BackendSnapshot& s, const TeamGraph&) { before.push_back(s); };
    TeamGraphJournal journal(dir, "robot_a", /*resume=*/false);
    Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), hooks,
                  Worker::Threading::kCaller);
    EXPECT_EQ(worker.keepJournal(journal), 0U);
    for (int i = 0; i < 30; ++i) {
      worker.add(Worker::OwnKeyframe{"robot_a", KeyframeId(i), fromSeconds(i), own_[i]});
      worker.add(Worker::PeerKeyframe{"robot_b", KeyframeId(100 + i), odom_b_[i]});
    }
    for (int i = 0; i <= 14; ++i) {
      LoopClosureData l = loop(i, i);
      l.method = "fabmap";
      l.odom_pose_from = own_[i];
      EXPECT_TRUE(worker.addOwnLoop(l));
    }
    worker.add(Worker::PeerKeyframe{"robot b", 999, odom_b_[0]});  // a name it cannot keep
    worker.tick();
  }  // killed: nothing more is written
  ASSERT_FALSE(before.empty());
  ASSERT_TRUE(before.back().team.at(0).in_graph);
  EXPECT_EQ(unjournaled.size(), 1U);
  std::ofstream(dir + "/team_graph_inputs", std::ios::app) << "K robot_a 30 3000000";  // cut short

  hooks.optimized = [&](const BackendSnapshot& s, const TeamGraph&) { after.push_back(s); };
  TeamGraphJournal journal(dir, "robot_a", /*resume=*/true);
  Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), hooks,
                Worker::Threading::kCaller);
  EXPECT_EQ(worker.keepJournal(journal), 30U + 30U + 15U)
      << "every input but the unnamed and the cut short";
  ASSERT_EQ(after.size(), 1U) << "resumed inputs are optimised at once";
  const BackendSnapshot& was = before.back();
  const BackendSnapshot& is = after.back();
  ASSERT_EQ(is.ids, was.ids);
  // One solve from the start against the run's solves at each closure: the same optimum.
  for (std::size_t k = 0; k < was.poses.size(); ++k) {
    EXPECT_LT((is.poses[k].translation() - was.poses[k].translation()).norm(), 1e-3) << k;
  }
  ASSERT_EQ(is.team.size(), 1U);
  EXPECT_TRUE(is.team[0].in_graph);
  EXPECT_LT(
      (is.team[0].alignment.transform.translation() - was.team[0].alignment.transform.translation())
          .norm(),
      1e-3);
  EXPECT_EQ(is.loops.inter, was.loops.inter);

  // The resumed run goes on, and its inputs join the journal after the first run's.
  worker.add(Worker::OwnKeyframe{"robot_a", 1030, fromSeconds(30), own_[30]});
  worker.tick();
  EXPECT_EQ(after.back().ids.back(), 1030U);
  EXPECT_EQ(TeamGraphJournal(dir, "robot_a", true).takeSaved().size(), 76U);

  // Another robot's journal, or a line that is not an input, is refused by name.
  EXPECT_THROW(TeamGraphJournal(dir, "robot_b", true), std::runtime_error);
  std::ofstream(dir + "/team_graph_inputs", std::ios::app) << "K robot_a 1031 nan\n";
  try {
    TeamGraphJournal bad(dir, "robot_a", true);
    ADD_FAILURE() << "a line that is not an input was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("team_graph_inputs:78"), std::string::npos) << e.what();
  }
  // Without resume a new mission starts the file anew; the last mission's stays beside.
  EXPECT_TRUE(TeamGraphJournal(dir, "robot_a", false).takeSaved().empty());
  EXPECT_TRUE(TeamGraphJournal(dir, "robot_a", true).takeSaved().empty());
  std::ifstream previous(dir + "/team_graph_inputs.previous");
  const std::string text((std::istreambuf_iterator<char>(previous)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("K robot_a 1031 nan"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(TeamGraphJournal, EachInputReadsBackExactlyAndALineThatIsNotOneIsRefused) {
  using Worker = TeamGraphWorker;
  const Pose3 pose = Pose3(Eigen::Translation3d(1.0 / 3.0, -2e-7, 1e5)) *
                     Eigen::AngleAxisd(0.1234567890123, Eigen::Vector3d(1, 2, 3).normalized());
  LoopClosureData loop;
  loop.robot_from = "robot_b";
  loop.keyframe_from = 7;
  loop.robot_to = "robot_c";
  loop.keyframe_to = (KeyframeId{1} << 55) + 3;
  loop.relative = pose;
  loop.covariance = Matrix6::Identity() * 1e-4;
  loop.covariance(0, 1) = loop.covariance(1, 0) = 3e-5;
  loop.odom_pose_to = pose.inverse();
  loop.match_score = 0.9;
  loop.fitness_m2 = 0.01;
  loop.inliers = 42;
  loop.method = "scan_context";
  const std::vector<TeamGraphJournal::Input> inputs = {
      Worker::OwnKeyframe{"robot_a", 12, -5, pose},
      Worker::PeerKeyframe{"robot_b", 13, pose.inverse()}, loop};
  for (const auto& input : inputs) {
    const std::string line = TeamGraphJournal::format(input);
    const auto read = TeamGraphJournal::parse(line);
    ASSERT_TRUE(read) << line;
    EXPECT_EQ(TeamGraphJournal::format(*read), line);
  }
  const auto read =
      std::get<LoopClosureData>(*TeamGraphJournal::parse(TeamGraphJournal::format(loop)));
  EXPECT_EQ(read.relative.matrix(), loop.relative.matrix()) << "exact, not approximate";
  EXPECT_EQ(read.covariance, loop.covariance);
  EXPECT_FALSE(read.odom_pose_from);
  EXPECT_EQ(read.odom_pose_to->matrix(), loop.odom_pose_to->matrix());
  EXPECT_EQ(read.keyframe_to, loop.keyframe_to);
  EXPECT_EQ(read.method, "scan_context");
  const std::string own = TeamGraphJournal::format(inputs[0]);
  for (const std::string& bad :
       {std::string(""), std::string("X robot_a 1"), own + " 1", own.substr(0, own.size() / 2),
        std::string("K robot_a -1 0 1 0 0 0 0 1 0 0 0 0 1 0"),
        std::string("K robot_a 1 0 2 0 0 0 0 1 0 0 0 0 1 0"),  // not a rotation
        std::string("K robot_a 99999999999999999999 0 1 0 0 0 0 1 0 0 0 0 1 0")}) {
    EXPECT_FALSE(TeamGraphJournal::parse(bad)) << bad;
  }
}

TEST(TeamGraph, PositionVariancesGrowAlongOdometryAndShrinkWithALoop) {
  // 30 keyframes 1 m apart around a 10 m x 5 m rectangle; then a loop from the last to the
  // first.
  TeamGraph graph("robot_a", BackendParams{});
  std::vector<Pose3> poses;
  for (int i = 0; i < 30; ++i) {
    const double s = i % 30;
    Eigen::Vector3d p = s < 10   ? Eigen::Vector3d(s, 0, 0)
                        : s < 15 ? Eigen::Vector3d(10, s - 10, 0)
                        : s < 25 ? Eigen::Vector3d(25 - s, 5, 0)
                                 : Eigen::Vector3d(0, 30 - s, 0);
    poses.push_back(Pose3(Eigen::Translation3d(p)));
    ASSERT_TRUE(graph.addKeyframe(i, fromSeconds(i), poses.back()));
  }
  graph.optimize();
  std::vector<KeyframeId> ids;
  for (KeyframeId i = 0; i < 30; ++i) ids.push_back(i);
  const auto open = graph.positionVariances(ids);
  ASSERT_TRUE(open);
  EXPECT_EQ((*open)[0], 0.0) << "the gauge keyframe";
  // Farther along the path, more uncertain (not strictly at each corner, where heading error
  // turns into the other axis).
  for (std::size_t i = 4; i < 30; ++i) EXPECT_GT((*open)[i], (*open)[i - 3]) << i;

  LoopClosureData loop;
  loop.robot_from = loop.robot_to = "robot_a";
  loop.keyframe_from = 29;
  loop.keyframe_to = 0;
  loop.relative = poses[29].inverse() * poses[0];
  loop.covariance = Matrix6::Identity() * 1e-4;
  ASSERT_TRUE(graph.addLoopClosure(loop));
  graph.optimize();
  const auto closed = graph.positionVariances(ids);
  ASSERT_TRUE(closed);
  EXPECT_LT((*closed)[29], 0.2 * (*open)[29]);
  EXPECT_LT((*closed)[15], (*open)[15]);
  EXPECT_FALSE(graph.positionVariances({99})) << "an unknown keyframe";
}

/// robot_a's closure from keyframe `from` to `to`, measured exactly.
LoopClosureData ownLoop(const std::vector<Pose3>& poses, KeyframeId from, KeyframeId to) {
  LoopClosureData loop;
  loop.robot_from = loop.robot_to = "robot_a";
  loop.keyframe_from = from;
  loop.keyframe_to = to;
  loop.relative = poses[from].inverse() * poses[to];
  loop.covariance = Matrix6::Identity() * 1e-4;
  return loop;
}

TEST(TeamGraphWorker, OptimisesOnATickAndReportsWhatItRefused) {
  using Worker = TeamGraphWorker;
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<BackendSnapshot> snapshots;
  std::vector<std::pair<Worker::Refusal, std::string>> refusals;
  int batches = 0;
  Worker::Hooks hooks;
  hooks.run = [&](const std::function<BackendSnapshot()>& batch) {
    ++batches;  // the worker's thread only
    return batch();
  };
  hooks.optimized = [&](const BackendSnapshot& snapshot, const TeamGraph& graph) {
    EXPECT_TRUE(graph.positionVariances(snapshot.ids)) << "the graph can be asked more";
    std::lock_guard<std::mutex> lock(mutex);
    snapshots.push_back(snapshot);
    changed.notify_all();
  };
  hooks.refused = [&](Worker::Refusal why, const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex);
    refusals.emplace_back(why, what);
  };
  // Generous: the worker shares a slow machine with everything else.
  const auto optimised = [&](std::size_t n) {
    std::unique_lock<std::mutex> lock(mutex);
    return changed.wait_for(lock, std::chrono::seconds(60), [&] { return snapshots.size() >= n; });
  };
  std::vector<Pose3> poses;
  {
    Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), hooks);
    for (KeyframeId id = 0; id < 5; ++id) {
      poses.push_back(Pose3(Eigen::Translation3d(double(id), 0.0, 0.0)));
      worker.add(Worker::OwnKeyframe{"robot_a", id, fromSeconds(100.0 + id), poses.back()});
    }
    worker.add(Worker::OwnKeyframe{"robot_a", 2, fromSeconds(106.0), poses[2]});  // ids increase
    worker.add(Worker::OwnKeyframe{"robot_b", 9, fromSeconds(107.0), poses[2]});
    worker.add(Worker::OwnKeyframe{"robot_a", 9, fromSeconds(107.0), std::nullopt});
    worker.add(Worker::PeerKeyframe{"robot_a", 9, poses[2]});
    worker.add(Worker::PeerKeyframe{"robot_b", 9, std::nullopt});
    worker.tick();
    ASSERT_TRUE(optimised(1));
    {
      std::lock_guard<std::mutex> lock(mutex);
      EXPECT_EQ(snapshots[0].poses.size(), 5U);
      // Refused at once: not this robot's or not a teammate's, no valid pose; then by the graph.
      ASSERT_EQ(refusals.size(), 5U);
      EXPECT_EQ(refusals[0].second, "keyframe 9 of 'robot_b': not this robot's");
      EXPECT_EQ(refusals[1].second, "keyframe 9 of 'robot_a': its pose is not finite");
      EXPECT_EQ(refusals[2].first, Worker::Refusal::kPeerKeyframe);
      EXPECT_EQ(refusals[2].second, "keyframe 9 of 'robot_a': not a teammate's");
      EXPECT_EQ(refusals[3].second, "keyframe 9 of 'robot_b': its pose is not finite");
      EXPECT_EQ(refusals[4].first, Worker::Refusal::kKeyframe);
      EXPECT_EQ(refusals[4].second, "keyframe 2: ids must increase");
      refusals.clear();
    }
    // A loop closure is solved at the next tick; the same one again is a duplicate (a teammate
    // found it too).
    const LoopClosureData loop = ownLoop(poses, 0, 4);
    EXPECT_FALSE(worker.addOwnLoop(loop)) << "an intra-robot closure stays with this robot";
    worker.tick();
    ASSERT_TRUE(optimised(2));
    worker.addOwnLoop(loop);
    worker.tick();
    ASSERT_TRUE(optimised(3));
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(snapshots[1].loops.intra, 1);
    ASSERT_EQ(refusals.size(), 1U);
    EXPECT_EQ(refusals[0].first, Worker::Refusal::kDuplicateLoopClosure);
    EXPECT_EQ(refusals[0].second, "loop closure robot_a/0 -> robot_a/4: known");
  }  // stops and joins
  EXPECT_EQ(batches, 3) << "a batch per optimisation";
}

TEST(TeamGraphWorker, OnTheCallersThreadEachCallReturnsWithItsOptimisationDone) {
  using Worker = TeamGraphWorker;
  std::vector<BackendSnapshot> snapshots;
  const auto caller = std::this_thread::get_id();
  Worker::Hooks hooks;
  hooks.optimized = [&](const BackendSnapshot& snapshot, const TeamGraph&) {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    snapshots.push_back(snapshot);
  };
  Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), hooks,
                Worker::Threading::kCaller);
  std::vector<Pose3> poses;
  for (KeyframeId id = 0; id < 5; ++id) {
    poses.push_back(Pose3(Eigen::Translation3d(double(id), 0.0, 0.0)));
    worker.add(Worker::OwnKeyframe{"robot_a", id, fromSeconds(100.0 + id), poses.back()});
  }
  EXPECT_TRUE(snapshots.empty()) << "keyframes wait for a tick";
  worker.tick();
  ASSERT_EQ(snapshots.size(), 1U);
  EXPECT_EQ(snapshots[0].poses.size(), 5U);
  EXPECT_FALSE(snapshots[0].cut_short);
  worker.tick();
  EXPECT_EQ(snapshots.size(), 1U) << "nothing new: no optimisation";
  const LoopClosureData loop = ownLoop(poses, 0, 4);
  worker.addOwnLoop(loop);
  EXPECT_EQ(snapshots.size(), 1U) << "a loop closure waits for a tick";
  worker.tick();
  ASSERT_EQ(snapshots.size(), 2U);
  EXPECT_EQ(snapshots[1].loops.intra, 1);
  EXPECT_EQ(snapshots[1].solved, BackendSnapshot::Solve::kFull) << "the first solve";
  std::vector<double> switches;
  std::vector<std::string> robots;
  EXPECT_TRUE(worker.inspect([&](const TeamGraph& graph) {
    EXPECT_EQ(graph.exportGraph(&switches, &robots).poses.size(), 5U);
  }));
}

TEST(TeamGraphWorker, AnOptimisationCutShortByItsTimeBoundRunsAgainInTheWindowOnTheNextTick) {
  using Worker = TeamGraphWorker;
  std::vector<BackendSnapshot> snapshots;
  Worker::Hooks hooks;
  hooks.optimized = [&](const BackendSnapshot& snapshot, const TeamGraph&) {
    snapshots.push_back(snapshot);
  };
  BackendParams params;
  params.max_solve_time_s = 0.001;  // far less than 300 keyframes take on any machine
  Worker worker(std::make_unique<TeamGraph>("robot_a", params), hooks, Worker::Threading::kCaller);
  std::vector<Pose3> poses;
  for (KeyframeId id = 0; id < 300; ++id) {
    poses.emplace_back(Eigen::Translation3d(std::cos(0.05 * id), std::sin(0.05 * id), 0.0));
    worker.add(Worker::OwnKeyframe{"robot_a", id, fromSeconds(100.0 + id), poses.back()});
  }
  worker.addOwnLoop(ownLoop(poses, 0, 299));  // something to solve
  worker.tick();
  ASSERT_EQ(snapshots.size(), 1U);
  EXPECT_TRUE(snapshots[0].cut_short) << snapshots[0].solve_s << " s";
  EXPECT_EQ(snapshots[0].solved, BackendSnapshot::Solve::kFull) << "the first solve";
  worker.tick();
  ASSERT_EQ(snapshots.size(), 2U) << "nothing new, but the last result was cut short";
  // The whole graph goes on at the next full_solve_period_s, not at every tick: a graph too
  // large for the time box would cost the box at every tick.
  EXPECT_EQ(snapshots[1].solved, BackendSnapshot::Solve::kWindow);
}

TEST(TeamGraphWorker, RoutesLoopClosuresByWhoFoundThemAndRefusesWhatCannotBeUsed) {
  using Worker = TeamGraphWorker;
  std::mutex mutex;
  std::vector<std::pair<Worker::Refusal, std::string>> refusals;
  Worker::Hooks hooks;
  hooks.refused = [&](Worker::Refusal why, const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex);
    refusals.emplace_back(why, what);
  };
  Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), hooks);
  LoopClosureData loop;
  loop.robot_from = "robot_a";
  loop.robot_to = "robot_b";
  loop.keyframe_to = 3;
  loop.covariance = Matrix6::Identity() * 1e-4;
  EXPECT_TRUE(worker.addOwnLoop(loop)) << "an inter-robot closure goes to the teammates too";
  LoopClosureData others = loop;
  others.robot_from = "robot_c";
  EXPECT_FALSE(worker.addOwnLoop(others));
  LoopClosureData broken = loop;
  broken.covariance(2, 2) = -1.0;
  EXPECT_FALSE(worker.addOwnLoop(broken));
  // From a teammate: "from" is its keyframe, with that keyframe's odometry pose.
  LoopClosureData sent = loop;
  sent.robot_from = "robot_b";
  sent.robot_to = "robot_a";
  worker.addTeammateLoop(sent);  // no odom_pose_from
  worker.addTeammateLoop(loop);  // robot_a's own coming back
  sent.odom_pose_from = Pose3::Identity();
  worker.addTeammateLoop(sent);  // used: no refusal
  // Between two teammates (robot_c found it): used: no refusal.
  others.odom_pose_from = others.odom_pose_to = Pose3::Identity();
  worker.addTeammateLoop(others);
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(refusals.size(), 4U);
  EXPECT_EQ(refusals[0].first, Worker::Refusal::kLoopClosure);
  EXPECT_EQ(refusals[0].second,
            "loop closure robot_c/0 -> robot_b/3: it does not involve this robot");
  EXPECT_EQ(refusals[1].first, Worker::Refusal::kLoopClosure);
  EXPECT_EQ(refusals[1].second,
            "loop closure robot_a/0 -> robot_b/3: covariance not finite and positive definite");
  EXPECT_EQ(refusals[2].first, Worker::Refusal::kTeammateLoopClosure);
  EXPECT_EQ(refusals[2].second, "loop closure robot_b/0 -> robot_a/3: no odom_pose_from");
  EXPECT_EQ(refusals[3].first, Worker::Refusal::kIgnoredLoopClosure);
}

TEST(TeamGraphWorker, InspectRunsATaskWithTheGraphOnTheWorkersThreadAndWaitsForIt) {
  using Worker = TeamGraphWorker;
  Worker worker(std::make_unique<TeamGraph>("robot_a", BackendParams{}), Worker::Hooks{});
  for (KeyframeId id = 0; id < 3; ++id) {
    worker.add(Worker::OwnKeyframe{"robot_a", id, fromSeconds(100.0 + id),
                                   Pose3(Eigen::Translation3d(double(id), 0.0, 0.0))});
  }
  worker.tick();
  // The tick's optimisation comes first or the task sees an unoptimised graph: await the one
  // holding all three keyframes.
  std::size_t poses = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::thread::id worker_thread;
  while (poses < 3 && std::chrono::steady_clock::now() < deadline) {
    ASSERT_TRUE(worker.inspect([&](const TeamGraph& graph) {
      std::vector<double> switches;
      std::vector<std::string> robots;
      poses = graph.exportGraph(&switches, &robots).poses.size();
      worker_thread = std::this_thread::get_id();
    }));
  }
  EXPECT_EQ(poses, 3U);
  EXPECT_NE(worker_thread, std::this_thread::get_id());
  EXPECT_THROW(worker.inspect([](const TeamGraph&) { throw std::runtime_error("disk full"); }),
               std::runtime_error);
  EXPECT_TRUE(worker.inspect([](const TeamGraph&) {})) << "the worker survives a failed task";
}

TEST(TeamGraphWorker, RefusalsAreDroppedOnTheirTopicsFlowOrOnlyCountedWhenNothingIsWrong) {
  using Worker = TeamGraphWorker;
  using R = Worker::Refusal;
  const std::vector<std::tuple<R, std::string, bool>> expected = {
      {R::kKeyframe, "keyframes", true},
      {R::kPeerKeyframe, "teammate_scans", true},
      {R::kLoopClosure, "loop_closures", true},
      {R::kTeammateLoopClosure, "inbox/loop_closures", true},
      {R::kIgnoredLoopClosure, "ignored inbox/loop_closures (this robot's own)", false},
      {R::kDuplicateLoopClosure, "duplicate loop_closures", false}};
  for (const auto& [why, flow, dropped] : expected) {
    EXPECT_EQ(Worker::reportOf(why).flow, flow);
    EXPECT_EQ(Worker::reportOf(why).dropped, dropped) << flow;
  }
}

TEST(BackendStage, EachOptimisationComesOutWithTheUncertaintyWhenAskedAndRefusalsAsNotices) {
  std::vector<BackendStage::Output> outputs;
  std::vector<BackendStage::Refusal> refusals;
  std::map<std::string, int> runs;
  bool wants_uncertainty = true;
  BackendStage::Hooks hooks;
  hooks.run = [&](const char* stage, const std::function<void()>& work) {
    ++runs[stage];
    work();
  };
  hooks.optimized = [&](const BackendStage::Output& out) { outputs.push_back(out); };
  hooks.refused = [&](const BackendStage::Refusal& r) { refusals.push_back(r); };
  hooks.wants_uncertainty = [&] { return wants_uncertainty; };
  BackendStage stage("robot_a", BackendParams{}, hooks, BackendStage::Threading::kCaller);
  for (KeyframeId id = 0; id < 4; ++id) {
    stage.add(BackendStage::OwnKeyframe{"robot_a", id, fromSeconds(1.0 + id),
                                        Pose3(Eigen::Translation3d(double(id), 0.0, 0.0))});
  }
  stage.tick();
  ASSERT_EQ(outputs.size(), 1U);
  EXPECT_EQ(outputs[0].snapshot.ids.size(), 4U);
  ASSERT_TRUE(outputs[0].uncertainty);
  ASSERT_EQ(outputs[0].uncertainty->size(), 4U);
  EXPECT_LT(outputs[0].uncertainty->front(), outputs[0].uncertainty->back())
      << "u_k grows along odometry";
  EXPECT_EQ(runs["optimise"], 1);
  EXPECT_EQ(runs["uncertainty"], 1);
  wants_uncertainty = false;  // nobody listens: the marginals are not computed
  stage.add(BackendStage::OwnKeyframe{"robot_a", 4, fromSeconds(5.0),
                                      Pose3(Eigen::Translation3d(4.0, 0.0, 0.0))});
  stage.tick();
  ASSERT_EQ(outputs.size(), 2U);
  EXPECT_FALSE(outputs[1].uncertainty);
  EXPECT_EQ(runs["uncertainty"], 1);

  // A keyframe of another robot on the own topic is dropped; a teammate's closure coming back
  // is only set aside; a closure with a teammate goes to the teammates too.
  stage.add(BackendStage::OwnKeyframe{"robot_b", 9, fromSeconds(6.0), Pose3::Identity()});
  LoopClosureData loop;
  loop.robot_from = "robot_a";
  loop.keyframe_from = 1;
  loop.robot_to = "robot_b";
  loop.keyframe_to = 3;
  loop.covariance = Matrix6::Identity() * 1e-4;
  loop.odom_pose_to = Pose3::Identity();
  EXPECT_TRUE(stage.addOwnLoop(loop));
  stage.addTeammateLoop(loop);
  ASSERT_GE(refusals.size(), 2U);
  EXPECT_EQ(refusals.front().notice.kind, "keyframes");
  EXPECT_TRUE(refusals.front().dropped);
  EXPECT_NE(refusals.front().notice.text.find("keyframe 9 of 'robot_b'"), std::string::npos)
      << refusals.front().notice.text;
  EXPECT_EQ(refusals.back().notice.kind, "ignored inbox/loop_closures (this robot's own)");
  EXPECT_FALSE(refusals.back().dropped);
}

TEST(BackendStage, MarginalsAtMostOncePerPeriodAndNewerKeyframesByOdometryBetween) {
  std::vector<BackendStage::Output> outputs;
  std::map<std::string, int> runs;
  BackendStage::Hooks hooks;
  hooks.run = [&](const char* stage, const std::function<void()>& work) {
    ++runs[stage];
    work();
  };
  hooks.optimized = [&](const BackendStage::Output& out) { outputs.push_back(out); };
  BackendParams params;
  params.uncertainty_period_s = 10.0;
  BackendStage stage("robot_a", params, hooks, BackendStage::Threading::kCaller);
  auto keyframe = [&](KeyframeId id) {
    stage.add(BackendStage::OwnKeyframe{"robot_a", id, fromSeconds(double(id)),
                                        Pose3(Eigen::Translation3d(2.0 * double(id), 0.0, 0.0))});
    if (id > 0) stage.tick();
  };
  for (KeyframeId id = 0; id < 4; ++id) keyframe(id);
  EXPECT_EQ(runs["uncertainty"], 1) << "keyframes 2 and 3 came within 10 s of the first solve";
  ASSERT_EQ(outputs.size(), 3U);
  const auto& between = *outputs.back().uncertainty;
  ASSERT_EQ(between.size(), 4U);
  // 2 m of odometry at 0.05 m per m: 0.01 m^2 more per keyframe.
  EXPECT_NEAR(between[3] - between[2], 0.01, 1e-12);
  for (KeyframeId id = 4; id < 12; ++id) keyframe(id);
  EXPECT_EQ(runs["uncertainty"], 2) << "again at 11 s";
  const auto& fresh = *outputs.back().uncertainty;
  ASSERT_EQ(fresh.size(), 12U);
  EXPECT_LT(fresh[1], fresh[11]) << "u_k grows along odometry";
}

TEST(BackendStage, ResumesWhatItsJournalKeptAndSavesItsFiles) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("ccir_backend_stage_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto drive = [](BackendStage& stage, KeyframeId from, KeyframeId to) {
    for (KeyframeId id = from; id < to; ++id) {
      stage.add(BackendStage::OwnKeyframe{"robot_a", id, fromSeconds(1.0 + id),
                                          Pose3(Eigen::Translation3d(double(id), 0.0, 0.0))});
    }
    stage.tick();
  };
  {
    BackendStage first("robot_a", BackendParams{}, {}, BackendStage::Threading::kCaller);
    first.openJournal(dir.string(), false);
    EXPECT_EQ(first.keepJournal(), 0U) << "a new mission";
    drive(first, 0, 6);
    const auto files = first.save(dir.string());
    ASSERT_TRUE(files);
    EXPECT_FALSE(files->empty());
    for (const auto& file : *files) EXPECT_TRUE(std::filesystem::exists(file)) << file;
  }
  std::vector<BackendStage::Output> outputs;
  BackendStage::Hooks hooks;
  hooks.optimized = [&](const BackendStage::Output& out) { outputs.push_back(out); };
  BackendStage resumed("robot_a", BackendParams{}, hooks, BackendStage::Threading::kCaller);
  resumed.openJournal(dir.string(), true);
  EXPECT_EQ(resumed.keepJournal(), 6U);
  ASSERT_EQ(outputs.size(), 1U) << "what it resumed is optimised at once";
  EXPECT_EQ(outputs[0].snapshot.ids.size(), 6U);
  drive(resumed, 6, 8);
  EXPECT_EQ(outputs.back().snapshot.ids.size(), 8U);
  EXPECT_THROW(resumed.openJournal("/proc/ccir_mapping_cannot_write", true), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ccir_mapping::core::backend
