// The parts that bound a loop-closure search: the spatial index of places, the pose gate and
// the verification queue's budget and horizon.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ccir_mapping/core/place_recognition/place_positions.h"
#include "ccir_mapping/core/place_recognition/pose_gate.h"
#include "ccir_mapping/core/place_recognition/verification_queue.h"

namespace ccir_mapping::core::place_recognition {
namespace {

TEST(PlacePositions, FindsExactlyThePlacesWithinTheRadiusAsTheyAreAdded) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  PlacePositions index;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 500; ++i) {
    points.emplace_back(u(rng), u(rng), 0.1 * u(rng));
    index.add(static_cast<std::size_t>(1000 + i), points.back());  // the caller's numbering
    if (i % 50 != 49) continue;
    const Eigen::Vector3d centre(u(rng), u(rng), 0.0);
    std::vector<std::size_t> expected;
    for (std::size_t j = 0; j < points.size(); ++j) {
      if ((points[j] - centre).norm() <= 30.0) expected.push_back(1000 + j);
    }
    auto found = index.within(centre, 30.0);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, expected) << "after " << points.size() << " places";
  }
  EXPECT_EQ(index.size(), 500U);
  EXPECT_TRUE(PlacePositions().within(Eigen::Vector3d::Zero(), 10.0).empty());
}

TEST(PoseGate, AllowsTheDriftOfThePathSinceTheAnchorUpToItsBound) {
  PoseGate::Params params;
  params.drift_m_per_m = 0.1;
  params.max_drift_m = 10.0;
  params.reach_m = 5.0;
  params.max_anchors = 2;
  PoseGate gate(params);
  // The other frame is this one shifted 50 m along x.
  GateAnchor anchor;
  anchor.other_in_own = Pose3(Eigen::Translation3d(50.0, 0.0, 0.0));
  anchor.own_path_m = 100.0;
  anchor.other_position = Eigen::Vector3d::Zero();
  anchor.other_path_m = 0.0;
  const GateKeyframe other{Eigen::Vector3d(0.0, 0.0, 0.0), 0.0};
  // At the anchor itself: 1 m of base allowance plus the reach.
  EXPECT_DOUBLE_EQ(gate.ratio(anchor, {Eigen::Vector3d(56.0, 0, 0), 100.0}, other), 1.0);
  EXPECT_GT(gate.ratio(anchor, {Eigen::Vector3d(57.0, 0, 0), 100.0}, other), 1.0);
  // 30 m of own path later, 3 m more may have drifted.
  EXPECT_DOUBLE_EQ(gate.ratio(anchor, {Eigen::Vector3d(59.0, 0, 0), 130.0}, other), 1.0);
  // ... but never more than max_drift_m.
  EXPECT_DOUBLE_EQ(gate.ratio(anchor, {Eigen::Vector3d(65.0, 0, 0), 1000.0}, other), 1.0);
  EXPECT_GT(gate.ratio(anchor, {Eigen::Vector3d(66.0, 0, 0), 1000.0}, other), 1.0);
  // A teammate's path is unknown here: its straight-line distance from the anchor stands for it.
  anchor.other_path_m.reset();
  const GateKeyframe moved{Eigen::Vector3d(0.0, 20.0, 0.0), std::nullopt};
  EXPECT_DOUBLE_EQ(gate.ratio(anchor, {Eigen::Vector3d(50.0, 28.0, 0), 100.0}, moved), 1.0);
  EXPECT_DOUBLE_EQ(gate.searchRadius(), 15.0);

  EXPECT_TRUE(gate.anchors("robot_b").empty());
  for (double path : {1.0, 2.0, 3.0})
    gate.addAnchor("robot_b", {Pose3::Identity(), path, Eigen::Vector3d::Zero(), {}});
  ASSERT_EQ(gate.anchors("robot_b").size(), 2U) << "the newest max_anchors";
  EXPECT_EQ(gate.anchors("robot_b").front().own_path_m, 2.0);
  EXPECT_TRUE(gate.anchors("robot_c").empty());
}

VerificationQueue::Entry entry(double score, double queued_s, KeyframeId own = 0, int rank = 0) {
  VerificationQueue::Entry e;
  e.rank = rank;
  e.score = score;
  e.queued = fromSeconds(queued_s);
  e.own = own;
  e.teammate = "robot_b";
  return e;
}

TEST(VerificationQueue, ReleasesTheBestWithinTheBudgetOfMissionTime) {
  VerificationQueue queue(2.0, 60.0);
  for (int i = 0; i < 10; ++i) queue.push(entry(0.1 * i, 0.0, static_cast<KeyframeId>(i)));
  EXPECT_TRUE(queue.release(fromSeconds(0.0)).empty()) << "no budget accrued yet";
  const auto first = queue.release(fromSeconds(1.0));
  ASSERT_EQ(first.size(), 2U);
  EXPECT_EQ(first[0].own, 9U) << "best score first";
  EXPECT_EQ(first[1].own, 8U);
  EXPECT_EQ(queue.release(fromSeconds(1.25)).size(), 0U) << "half a verification";
  EXPECT_EQ(queue.release(fromSeconds(1.5)).size(), 1U);
  // A quiet spell buys at most one second's worth.
  EXPECT_EQ(queue.release(fromSeconds(30.0)).size(), 2U);
  EXPECT_EQ(queue.size(), 5U);
  // Time does not run backwards (a teammate's older stamp).
  EXPECT_TRUE(queue.release(fromSeconds(10.0)).empty());
  EXPECT_THROW(VerificationQueue(0.0, 60.0), std::invalid_argument);
  EXPECT_THROW(VerificationQueue(1.0, 0.0), std::invalid_argument);
}

TEST(VerificationQueue, EachQuerysBestComesFirstThenTheNewest) {
  VerificationQueue queue(1.0, 60.0);
  queue.push(entry(0.9, 0.0, 1, /*rank=*/1));  // a query's second, however well scored
  queue.push(entry(0.1, 0.0, 2, /*rank=*/0));
  queue.push(entry(0.1, 1.0, 3, /*rank=*/0));  // another query's best, newer
  queue.release(fromSeconds(1.0));
  std::vector<KeyframeId> order;
  for (double t : {2.0, 3.0, 4.0}) {
    for (const auto& e : queue.release(fromSeconds(t))) order.push_back(e.own);
  }
  EXPECT_EQ(order, (std::vector<KeyframeId>{3, 2, 1}));
}

TEST(VerificationQueue, DropsWhatWaitedLongerThanTheHorizon) {
  VerificationQueue queue(1.0, 10.0);
  queue.push(entry(0.9, 0.0, 1));
  queue.push(entry(0.1, 5.0, 2));
  queue.release(fromSeconds(0.0));
  const auto released = queue.release(fromSeconds(12.0));
  ASSERT_EQ(released.size(), 1U);
  EXPECT_EQ(released[0].own, 2U) << "the better one waited 12 s, past the horizon";
  EXPECT_EQ(queue.expired(), 1U);
  EXPECT_EQ(queue.size(), 0U);
}

}  // namespace
}  // namespace ccir_mapping::core::place_recognition
