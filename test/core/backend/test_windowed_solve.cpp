// The event-driven back end: TeamGraph solves only when a loop closure arrives, then only the
// newest keyframes (solve_window_keyframes) unless a full solve is due; judged against the same
// inputs solved whole every time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <Eigen/Geometry>

#include "ccir_mapping/core/backend/backend_stage.h"
#include "ccir_mapping/core/backend/team_graph.h"

namespace ccir_mapping::core::backend {
namespace {

using pose_graph::LoopClosureData;
using Solve = BackendSnapshot::Solve;

constexpr int kPerLap = 60;

/// Three laps of a 10 m circle, a keyframe per metre; odometry that turns 0.2 degrees a step
/// too many and overshoots by 1 %, so a lap ends ~2 m off.
struct Laps {
  std::vector<Pose3> truth;
  std::vector<Pose3> odometry;

  explicit Laps(int keyframes) {
    Pose3 odom = Pose3::Identity();
    for (int k = 0; k < keyframes; ++k) {
      const double angle = 2.0 * M_PI * k / kPerLap;
      Pose3 pose = Pose3::Identity();
      pose.translation() << 10.0 * std::sin(angle), 10.0 - 10.0 * std::cos(angle), 0.0;
      pose.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      if (k > 0) {
        Pose3 step = truth.back().inverse() * pose;
        step.translation() *= 1.01;
        step.linear() = step.linear() * Eigen::AngleAxisd(0.0035, Eigen::Vector3d::UnitZ());
        odom = odom * step;
      }
      truth.push_back(pose);
      odometry.push_back(odom);
    }
  }

  /// A closure from keyframe `from` back to `to`, measured exactly.
  LoopClosureData loop(int from, int to) const {
    LoopClosureData loop;
    loop.robot_from = loop.robot_to = "robot_a";
    loop.keyframe_from = static_cast<KeyframeId>(from);
    loop.keyframe_to = static_cast<KeyframeId>(to);
    loop.relative = truth[from].inverse() * truth[to];
    loop.covariance = Matrix6::Identity() * 1e-3;
    return loop;
  }
};

double largestGap(const BackendSnapshot& a, const BackendSnapshot& b) {
  double gap = 0.0;
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    gap = std::max(gap, (a.poses[i].translation() - b.poses[i].translation()).norm());
  }
  return gap;
}

double largestError(const BackendSnapshot& s, const std::vector<Pose3>& truth) {
  double error = 0.0;
  for (std::size_t i = 0; i < s.poses.size(); ++i) {
    error = std::max(error, (s.poses[i].translation() - truth[i].translation()).norm());
  }
  return error;
}

BackendParams params(int window, double full_period_s) {
  BackendParams p;
  p.solve_window_keyframes = window;
  p.full_solve_period_s = full_period_s;
  p.max_solve_time_s = 30.0;  // never the bound here: the results must not depend on speed
  return p;
}

TEST(WindowedSolve, KeyframesAloneAreOnlyPlacedAndALoopIsSolvedAtTheNextCall) {
  const Laps laps(kPerLap + 5);
  TeamGraph graph("robot_a", params(30, 3600.0));
  for (int k = 0; k <= kPerLap; ++k) {
    ASSERT_TRUE(graph.addKeyframe(k, fromSeconds(k), laps.odometry[k]));
  }
  const BackendSnapshot placed = graph.optimize();
  EXPECT_EQ(placed.solved, Solve::kNone);
  EXPECT_TRUE(placed.poses.back().isApprox(laps.odometry[kPerLap], 1e-9))
      << "no loop: odometry is the estimate";
  ASSERT_TRUE(graph.addLoopClosure(laps.loop(kPerLap, 0)));
  const BackendSnapshot first = graph.optimize();
  EXPECT_EQ(first.solved, Solve::kFull) << "the first solve";
  EXPECT_EQ(first.solved_poses, kPerLap);
  EXPECT_LT(largestError(first, laps.truth), 0.5 * largestError(placed, laps.truth));

  for (int k = kPerLap + 1; k < kPerLap + 5; ++k) {
    ASSERT_TRUE(graph.addKeyframe(k, fromSeconds(k), laps.odometry[k]));
  }
  const BackendSnapshot extended = graph.optimize();
  EXPECT_EQ(extended.solved, Solve::kNone);
  EXPECT_EQ(extended.poses.size(), kPerLap + 5U);
  EXPECT_EQ(largestGap(first, extended), 0.0) << "solved poses stay where the solve left them";
  ASSERT_TRUE(graph.addLoopClosure(laps.loop(kPerLap + 4, 4)));
  const BackendSnapshot windowed = graph.optimize();
  EXPECT_EQ(windowed.solved, Solve::kWindow);
  EXPECT_EQ(windowed.solved_poses, 30);
  for (int k = 0; k < kPerLap + 5 - 30; ++k) {
    EXPECT_EQ(windowed.poses[k].matrix(), extended.poses[k].matrix()) << k << " is held";
  }
}

TEST(WindowedSolve, ANewLoopBetweenHeldKeyframesOrMissedByMuchFreesThemBackToItsOlderEnd) {
  const Laps laps(2 * kPerLap);
  TeamGraph graph("robot_a", params(20, 3600.0));
  for (int k = 0; k < 2 * kPerLap; ++k) {
    ASSERT_TRUE(graph.addKeyframe(k, fromSeconds(k), laps.odometry[k]));
  }
  ASSERT_TRUE(graph.addLoopClosure(laps.loop(2 * kPerLap - 1, kPerLap - 1)));
  BackendSnapshot last = graph.optimize();
  EXPECT_EQ(last.solved, Solve::kFull) << "the first solve";
  ASSERT_TRUE(graph.addLoopClosure(laps.loop(2 * kPerLap - 2, kPerLap - 2)));
  last = graph.optimize();
  EXPECT_EQ(last.solved_poses, 20) << "a loop from the window, met: the window alone";
  ASSERT_TRUE(graph.addLoopClosure(laps.loop(kPerLap + 10, 10)));  // neither end in the window
  BackendSnapshot before = last;
  last = graph.optimize();
  EXPECT_EQ(last.solved, Solve::kWindow);
  EXPECT_EQ(last.solved_poses, 2 * kPerLap - 10) << "every keyframe from 10 on";
  for (int k = 0; k < 10; ++k) EXPECT_EQ(last.poses[k].matrix(), before.poses[k].matrix()) << k;
  // A loop from the window that the estimate misses by more than revisit_loop_error_m (1 m).
  LoopClosureData missed = laps.loop(2 * kPerLap - 3, kPerLap - 3);
  missed.relative.translation().x() += 0.6;
  ASSERT_TRUE(graph.addLoopClosure(missed));
  last = graph.optimize();
  EXPECT_EQ(last.solved_poses, 20) << "missed by 0.6 m: the window";
  missed = laps.loop(2 * kPerLap - 4, kPerLap - 30);
  missed.relative.linear() =
      missed.relative.linear() * Eigen::AngleAxisd(0.12, Eigen::Vector3d::UnitZ()).matrix();
  ASSERT_TRUE(graph.addLoopClosure(missed));
  before = last;
  last = graph.optimize();
  EXPECT_EQ(last.solved_poses, kPerLap + 30) << "turned by 0.12 rad, 1.2 m at 10 m: from 30 on";
  for (int k = 0; k < kPerLap - 30; ++k) {
    EXPECT_EQ(last.poses[k].matrix(), before.poses[k].matrix()) << k;
  }
}

TEST(WindowedSolve, EqualsTheFullSolveOfTheSameInputsWithinTolerance) {
  // Three laps closed against the first one every third keyframe, solved every fifth: once
  // with a window of 30 keyframes, once whole each time (window 0).
  const Laps laps(3 * kPerLap);
  TeamGraph windowed("robot_a", params(30, 3600.0));
  TeamGraph whole("robot_a", params(0, 3600.0));
  double worst_gap_m = 0.0;
  double largest_correction_m = 0.0;
  int windowed_solves = 0;
  BackendSnapshot w, f;
  for (int k = 0; k < 3 * kPerLap; ++k) {
    for (TeamGraph* graph : {&windowed, &whole}) {
      ASSERT_TRUE(graph->addKeyframe(k, fromSeconds(k), laps.odometry[k]));
      if (k >= kPerLap && k % 3 == 0) ASSERT_TRUE(graph->addLoopClosure(laps.loop(k, k % kPerLap)));
    }
    if (k % 5 != 4) continue;
    w = windowed.optimize();
    f = whole.optimize();
    ASSERT_NE(f.solved, Solve::kWindow);
    windowed_solves += w.solved == Solve::kWindow;
    worst_gap_m = std::max(worst_gap_m, largestGap(w, f));
    // What the full solve corrected of the odometry.
    for (int i = 0; i <= k; ++i) {
      largest_correction_m =
          std::max(largest_correction_m,
                   (f.poses[i].translation() - windowed.odometry().poses[i].translation()).norm());
    }
  }
  EXPECT_GT(windowed_solves, 20);
  EXPECT_GT(largest_correction_m, 2.0) << "a test the odometry alone fails";
  // Measured: 0.16 m of a 6.1 m correction; 0.222 m from the truth against 0.221 m.
  EXPECT_LT(worst_gap_m, 0.05 * largest_correction_m);
  EXPECT_LT(largestError(w, laps.truth), 1.1 * largestError(f, laps.truth));
}

/// b's keyframes (ids 1000 + k) and where they truly are, by id.
std::map<KeyframeId, Pose3> teammateOf(const BackendSnapshot& snapshot) {
  std::map<KeyframeId, Pose3> poses;
  for (const auto& peer : snapshot.peer_keyframes) {
    for (std::size_t k = 0; k < peer.ids.size(); ++k) poses[peer.ids[k]] = peer.poses[k];
  }
  return poses;
}

TEST(WindowedSolve, ATeammatesOlderKeyframesMoveInRigidBlocksCloseToTheFullSolve) {
  // robot_b drives the laps 15 keyframes ahead of robot_a with the opposite drift; a closes
  // loops to b's keyframes where b was 15 keyframes ago (in b's window) and a lap ago (in its
  // blocks once the window of 30 has passed them).
  constexpr int kAhead = 15;
  constexpr int kKeyframes = 3 * kPerLap;
  const Laps laps(kKeyframes + kAhead);
  std::vector<Pose3> odom_b{Pose3::Identity()};
  for (int k = 1; k < kKeyframes; ++k) {
    Pose3 step = laps.truth[k - 1 + kAhead].inverse() * laps.truth[k + kAhead];
    step.translation() *= 0.99;
    step.linear() = step.linear() * Eigen::AngleAxisd(-0.0035, Eigen::Vector3d::UnitZ());
    odom_b.push_back(odom_b.back() * step);
  }
  const auto to_b = [&](int k, int j) {
    LoopClosureData loop;
    loop.robot_from = "robot_a";
    loop.robot_to = "robot_b";
    loop.keyframe_from = static_cast<KeyframeId>(k);
    loop.keyframe_to = static_cast<KeyframeId>(1000 + j);
    loop.relative = laps.truth[k].inverse() * laps.truth[j + kAhead];
    loop.covariance = Matrix6::Identity() * 1e-3;
    return loop;
  };
  TeamGraph windowed("robot_a", params(30, 3600.0));
  TeamGraph whole("robot_a", params(0, 3600.0));
  double worst_gap_m = 0.0;
  double largest_correction_m = 0.0;
  int windowed_solves = 0;
  int most_solved = 0;
  double block_moved_m = 0.0;
  BackendSnapshot w, f;
  for (int k = 0; k < kKeyframes; ++k) {
    for (TeamGraph* graph : {&windowed, &whole}) {
      ASSERT_TRUE(graph->addKeyframe(k, fromSeconds(k), laps.odometry[k]));
      ASSERT_TRUE(graph->addPeerKeyframe("robot_b", 1000 + k, odom_b[k]));
      if (k >= kPerLap && k % 3 == 0) {
        ASSERT_TRUE(graph->addLoopClosure(laps.loop(k, k % kPerLap)));
      }
      if (k >= kAhead && k % 3 == 1) ASSERT_TRUE(graph->addLoopClosure(to_b(k, k - kAhead)));
      if (k >= kPerLap + kAhead && k % 3 == 2) {
        ASSERT_TRUE(graph->addLoopClosure(to_b(k, k - kAhead - kPerLap)));
      }
    }
    if (k % 5 != 4) continue;
    const auto before = teammateOf(w);
    w = windowed.optimize();
    f = whole.optimize();
    ASSERT_NE(f.solved, Solve::kWindow);
    if (w.solved == Solve::kWindow && before.count(1000)) {  // b joined (with a full solve)
      ++windowed_solves;
      most_solved = std::max(most_solved, w.solved_poses);
      // A revisit missed by much frees a's keyframes back to its older end; b's stay blocked.
      EXPECT_LE(w.solved_poses, k + 1 + 30 + 5 + kKeyframes / 20) << "a's, b's window and blocks";
      // b's oldest keyframes are in one block: moved as one (here barely: a's held keyframes saw
      // them too).
      const auto after = teammateOf(w);
      const Pose3 move = after.at(1000) * before.at(1000).inverse();
      block_moved_m = std::max(block_moved_m, move.translation().norm());
      EXPECT_TRUE(after.at(1010).isApprox(move * before.at(1010), 1e-6)) << k;
    }
    worst_gap_m = std::max(worst_gap_m, largestGap(w, f));
    const auto w_b = teammateOf(w);
    const auto f_b = teammateOf(f);
    ASSERT_EQ(w_b.size(), f_b.size());
    for (const auto& [id, pose] : f_b) {
      worst_gap_m = std::max(worst_gap_m, (w_b.at(id).translation() - pose.translation()).norm());
    }
    for (int i = 0; i <= k; ++i) {
      largest_correction_m =
          std::max(largest_correction_m,
                   (f.poses[i].translation() - windowed.odometry().poses[i].translation()).norm());
    }
  }
  ASSERT_EQ(teammateOf(w).size(), static_cast<std::size_t>(kKeyframes)) << "b joined";
  EXPECT_GE(windowed_solves, 5);
  EXPECT_GT(largest_correction_m, 2.0) << "a test the odometry alone fails";
  std::printf(
      "worst gap %.3f m of a %.2f m correction; %d windowed solves of at most %d poses; b's "
      "oldest block moved up to %.3f m\n",
      worst_gap_m, largest_correction_m, windowed_solves, most_solved, block_moved_m);
  EXPECT_LT(worst_gap_m, 0.05 * largest_correction_m);
  double error_w = 0.0;
  double error_f = 0.0;
  const auto b_w = teammateOf(w);
  const auto b_f = teammateOf(f);
  for (int j = 0; j < kKeyframes; ++j) {
    const Eigen::Vector3d truth = laps.truth[j + kAhead].translation();
    error_w = std::max(error_w, (b_w.at(1000 + j).translation() - truth).norm());
    error_f = std::max(error_f, (b_f.at(1000 + j).translation() - truth).norm());
  }
  std::printf("b from the truth: %.3f m windowed, %.3f m full\n", error_w, error_f);
  // Measured: b 0.36 m windowed, 0.42 m full; a 0.26 m, 0.15 m (a gap of 2 % of the correction).
  EXPECT_LT(error_w, error_f + 0.05 * largest_correction_m);
  EXPECT_LT(largestError(w, laps.truth), largestError(f, laps.truth) + 0.05 * largest_correction_m);
}

TEST(WindowedSolve, AFullSolveAtItsPeriodReturnsToTheBatchOptimumAndSaysHowFarItMoved) {
  const Laps laps(2 * kPerLap + 20);
  TeamGraph windowed("robot_a", params(20, 30.0));
  TeamGraph whole("robot_a", params(0, 3600.0));
  std::vector<BackendSnapshot> w;
  BackendSnapshot f;
  for (int k = 0; k < 2 * kPerLap + 20; ++k) {
    for (TeamGraph* graph : {&windowed, &whole}) {
      ASSERT_TRUE(graph->addKeyframe(k, fromSeconds(k), laps.odometry[k]));
      if (k >= kPerLap && k % 2 == 0) ASSERT_TRUE(graph->addLoopClosure(laps.loop(k, k % kPerLap)));
    }
    w.push_back(windowed.optimize());
    f = whole.optimize();
  }
  int full = 0;
  for (std::size_t k = 0; k < w.size(); ++k) {
    if (w[k].solved != Solve::kFull) continue;
    ++full;
    if (k > kPerLap + 1) {
      EXPECT_GT(w[k].full_correction_m, 0.0) << k << ": the window left something to correct";
    }
  }
  EXPECT_GE(full, 3) << "the first solve, then every 30 s of windowed ones";
  // The last full solve and the batch from scratch agree.
  std::size_t last_full = w.size() - 1;
  while (w[last_full].solved != Solve::kFull) --last_full;
  TeamGraph reference("robot_a", params(0, 3600.0));
  for (std::size_t k = 0; k <= last_full; ++k) {
    ASSERT_TRUE(reference.addKeyframe(k, fromSeconds(k), laps.odometry[k]));
    if (k >= kPerLap && k % 2 == 0)
      ASSERT_TRUE(reference.addLoopClosure(laps.loop(k, k % kPerLap)));
  }
  EXPECT_LT(largestGap(w[last_full], reference.optimize()), 0.01);
}

TEST(WindowedSolve, TheStageCountsEachKindOfSolveForDiagnostics) {
  const Laps laps(2 * kPerLap);
  BackendStage stage("robot_a", params(20, 3600.0), {}, BackendStage::Threading::kCaller);
  for (int k = 0; k < 2 * kPerLap; ++k) {
    stage.add(BackendStage::OwnKeyframe{"robot_a", static_cast<KeyframeId>(k), fromSeconds(k),
                                        laps.odometry[k]});
  }
  stage.tick();
  EXPECT_EQ(stage.latest().full_solves + stage.latest().windowed_solves, 0) << "no loop yet";
  stage.addOwnLoop(laps.loop(2 * kPerLap - 1, kPerLap - 1));
  stage.tick();
  stage.addOwnLoop(laps.loop(2 * kPerLap - 2, kPerLap - 2));
  stage.tick();
  const auto latest = stage.latest();
  EXPECT_EQ(latest.full_solves, 1);
  EXPECT_EQ(latest.windowed_solves, 1);
  EXPECT_GT(latest.full_correction_m, 0.5) << "the first full solve moved the drifted lap";
}

}  // namespace
}  // namespace ccir_mapping::core::backend
