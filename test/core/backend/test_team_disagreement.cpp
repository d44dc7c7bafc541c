// judgeDisagreement: when a teammate's EM transform differs from the graph's, who wins.
#include <gtest/gtest.h>

#include <cmath>

#include "ccir_mapping/core/backend/team_disagreement.h"

namespace ccir_mapping::core::backend {
namespace {

using Verdict = TeamDisagreement::Verdict;

Pose3 pose(double x_m, double yaw_deg) {
  Pose3 pose = Pose3::Identity();
  pose.translate(Eigen::Vector3d(x_m, 0, 0));
  pose.rotate(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()));
  return pose;
}

TEST(TeamDisagreement, WithinTheBoundsOrBackedByNoJudgedClosureIsAgreement) {
  const BackendParams params;  // 1 m, 5 deg, margin 3
  const Pose3 graph = pose(10, 30);
  const TeamDisagreement near =
      judgeDisagreement(graph, graph, graph * pose(0.9, 4.5), 0, 50, params);
  EXPECT_EQ(near.verdict, Verdict::kAgree);
  EXPECT_NEAR(near.shift_m, 0.9, 1e-9);
  EXPECT_NEAR(near.turn_deg, 4.5, 1e-9);
  // Far off, but none of the EM's inliers is a closure the graph has solved with yet.
  EXPECT_EQ(judgeDisagreement(graph, graph, graph * pose(5, 0), 0, 0, params).verdict,
            Verdict::kAgree);
}

TEST(TeamDisagreement, TheGraphKeepsItsTransformUnlessTheEmIsAheadByMoreThanTheMargin) {
  const BackendParams params;
  const Pose3 graph = pose(10, 30);
  const Pose3 em = graph * pose(3, 0);
  EXPECT_EQ(judgeDisagreement(graph, graph, em, 10, 13, params).verdict, Verdict::kKeepGraph);
  EXPECT_EQ(judgeDisagreement(graph, graph, em, 10, 14, params).verdict, Verdict::kPlaceAgain);
  // A turn alone disagrees too.
  const TeamDisagreement turned =
      judgeDisagreement(graph, graph, graph * pose(0, 8), 2, 20, params);
  EXPECT_EQ(turned.verdict, Verdict::kPlaceAgain);
  EXPECT_NEAR(turned.turn_deg, 8, 1e-9);
}

TEST(TeamDisagreement, ATeammateIsNotPlacedAgainWithTheTransformItWasPlacedWith) {
  const BackendParams params;
  const Pose3 placed_with = pose(10, 30);
  const Pose3 graph = placed_with * pose(3, 6);  // the graph moved away from it
  // The EM finds (nearly) the transform of the last placement: that was tried.
  EXPECT_EQ(
      judgeDisagreement(graph, placed_with, placed_with * pose(0.5, 2), 2, 20, params).verdict,
      Verdict::kTriedBefore);
  // A transform neither the graph nor the last placement had: placed again.
  EXPECT_EQ(
      judgeDisagreement(graph, placed_with, placed_with * pose(-3, -6), 2, 20, params).verdict,
      Verdict::kPlaceAgain);
}

}  // namespace
}  // namespace ccir_mapping::core::backend
