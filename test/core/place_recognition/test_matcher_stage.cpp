// The Matcher's stage on simulated VLP-16 keyframes of the mine with the shipped model: what each
// input returns (word sets, c_k, loop closures in both directions) and what it refuses, the
// decisions the Matcher nodelet and the team runner take from it.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "ccir_mapping/core/place_recognition/matcher_stage.h"
#include "ccir_mapping/core/preprocess/lidar_scan_cloud.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::place_recognition {
namespace {

using Cloud = MatcherStage::Cloud;

/// Keyframe clouds (as the Preprocessor makes them) of one robot's drive through the mine,
/// with the sensor's pose; the same place scanned again differs by its range noise.
class Scans {
 public:
  Scans() : mission_(params()) {}
  /// The sensor t seconds into the drive.
  Pose3 poseAt(double t) const {
    return mission_.robots().front().trajectory.poseAt(t) * mission_.sensorMount();
  }
  Cloud at(double t, std::uint64_t noise_seed) const {
    const Pose3 pose = poseAt(t);
    std::mt19937_64 rng(noise_seed);
    const LidarScan scan = mission_.lidar().scan(
        mission_.world(), 0, [&](double) { return pose; }, rng);
    const preprocess::ScanPreprocessor preprocessor(preprocess::PreprocessorParams{});
    return *preprocessor.process(preprocess::toCloud(scan), upInFrame(pose));
  }

 private:
  static simulation::MissionParams params() {
    simulation::MissionParams p;
    p.robots = 1;
    return p;
  }
  simulation::Mission mission_;
};

class MatcherStageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = PlaceModel::load(CCIR_MODEL_DIR);
    scans_ = new Scans();
  }
  static void TearDownTestSuite() { delete scans_; }

  MatcherStage stage(const std::string& robot = "robot_a") {
    MatcherStage::Hooks hooks;
    hooks.run = [this](const char* name, const std::function<void()>& work) {
      ++runs_[name];
      work();
    };
    return MatcherStage(robot, MatcherParams{}, model_, hooks);
  }
  /// An own keyframe of `stage` t seconds into the drive, as the nodelet hands it over.
  MatcherStage::Output own(MatcherStage& stage, KeyframeId id, double stamp_s, double t,
                           std::uint64_t seed, MatcherStage::Output* described = nullptr) {
    stage.addOwnTravel(1.0);
    DescribedKeyframe keyframe;
    auto first = stage.describeOwn(id, fromSeconds(stamp_s), scans_->at(t, seed), scans_->poseAt(t),
                                   &keyframe);
    if (described) *described = first;
    return stage.matchOwn(std::move(keyframe));
  }

  static std::shared_ptr<const PlaceModel> model_;
  static Scans* scans_;
  std::map<std::string, int> runs_;
};
std::shared_ptr<const PlaceModel> MatcherStageTest::model_;
Scans* MatcherStageTest::scans_ = nullptr;

TEST_F(MatcherStageTest, OwnKeyframesGiveWordSetsAndCloseLoopsBeyondTheExclusionWindow) {
  auto matcher = stage();
  MatcherStage::Output described;
  EXPECT_TRUE(own(matcher, 0, 0.0, 2.0, 1, &described).loop_closures.empty());
  ASSERT_TRUE(described.features);
  EXPECT_EQ(described.features->robot, "robot_a");
  EXPECT_EQ(described.features->id, 0U);
  EXPECT_EQ(described.features->vocabulary_hash, model_->vocabulary.hash());
  EXPECT_FALSE(described.features->words.empty());
  EXPECT_GT(described.features->descriptor_count, 0U);
  EXPECT_TRUE(described.correspondences.empty()) << "no teammate word set kept yet";
  EXPECT_TRUE(own(matcher, 1, 10.0, 12.0, 2).loop_closures.empty()) << "another place";
  // The first place again, 15 s later: too recent; 45 s later: a loop from the older keyframe.
  EXPECT_TRUE(own(matcher, 2, 15.0, 2.0, 3).loop_closures.empty());
  const auto out = own(matcher, 3, 45.0, 2.0, 4);
  ASSERT_EQ(out.loop_closures.size(), 1U);
  const auto& loop = out.loop_closures.front();
  EXPECT_EQ(loop.robot_from, "robot_a");
  EXPECT_TRUE(loop.keyframe_from == 0 || loop.keyframe_from == 2) << loop.keyframe_from;
  EXPECT_EQ(loop.robot_to, "robot_a");
  EXPECT_EQ(loop.keyframe_to, 3U);
  EXPECT_LT(loop.relative.translation().norm(), 0.2);
  ASSERT_TRUE(loop.odom_pose_from) << "an own place carries its odometry pose";
  EXPECT_GE(out.verified, 1U);
  EXPECT_EQ(matcher.matcher().places(), 4U);
  EXPECT_EQ(runs_["describe"], 4);
  EXPECT_GE(runs_["match"], 4);
}

TEST_F(MatcherStageTest, TeammatesWordSetsGiveCorrespondencesBothWays) {
  auto matcher = stage();
  own(matcher, 0, 0.0, 2.0, 1);
  // robot_b's word set of the same place: c_k of own keyframe 0 for it.
  DescribedKeyframe theirs;
  auto b = stage("robot_b");
  const auto words =
      *b.describeOwn(7, fromSeconds(1.0), scans_->at(2.0, 5), scans_->poseAt(2.0), &theirs)
           .features;
  const auto out = matcher.onTeammateWords(words);
  EXPECT_TRUE(out.refused.empty());
  ASSERT_EQ(out.correspondences.size(), 1U);
  EXPECT_EQ(out.correspondences.front().peer, "robot_b");
  EXPECT_EQ(out.correspondences.front().peer_keyframe, 7U);
  ASSERT_FALSE(out.correspondences.front().counts.empty());
  EXPECT_EQ(out.correspondences.front().counts.front().first, 0U);
  EXPECT_GE(out.correspondences.front().counts.front().second, MatcherParams{}.min_correspondences);
  // An own keyframe made later gets its c_k with that kept word set.
  MatcherStage::Output later;
  own(matcher, 1, 5.0, 2.0, 6, &later);
  ASSERT_EQ(later.correspondences.size(), 1U);
  EXPECT_EQ(later.correspondences.front().peer, "robot_b");
  EXPECT_EQ(later.correspondences.front().peer_keyframe, 7U);
  EXPECT_EQ(later.correspondences.front().counts.front().first, 1U);
}

TEST_F(MatcherStageTest, TeammatesScansCloseInterRobotLoopsEitherWayRound) {
  auto matcher = stage();
  own(matcher, 0, 0.0, 2.0, 1);
  // robot_b scanned the first place: a closure from the own place, with robot_b's pose.
  const Pose3 theirs(Eigen::Translation3d(-3.0, 1.0, 0.0));
  auto out =
      matcher.onTeammateScan("robot_b", 40, fromSeconds(2.0), scans_->at(2.0, 7), theirs, false);
  ASSERT_EQ(out.loop_closures.size(), 1U);
  EXPECT_EQ(out.loop_closures.front().robot_from, "robot_a");
  EXPECT_EQ(out.loop_closures.front().keyframe_from, 0U);
  EXPECT_EQ(out.loop_closures.front().robot_to, "robot_b");
  EXPECT_EQ(out.loop_closures.front().keyframe_to, 40U);
  ASSERT_TRUE(out.loop_closures.front().odom_pose_to);
  EXPECT_TRUE(out.loop_closures.front().odom_pose_to->isApprox(theirs));
  // robot_b scanned the second place before this robot got there: kept, then found by the own
  // keyframe, which is "from".
  out = matcher.onTeammateScan("robot_b", 41, fromSeconds(3.0), scans_->at(12.0, 8), theirs, false);
  EXPECT_TRUE(out.loop_closures.empty());
  EXPECT_EQ(matcher.matcher().keptScans(), 2U);
  out = own(matcher, 1, 10.0, 12.0, 9);
  ASSERT_EQ(out.loop_closures.size(), 1U);
  EXPECT_EQ(out.loop_closures.front().keyframe_from, 1U);
  EXPECT_EQ(out.loop_closures.front().robot_to, "robot_b");
  EXPECT_EQ(out.loop_closures.front().keyframe_to, 41U);
}

TEST_F(MatcherStageTest, RefusesItsOwnMessagesAndOtherVocabularies) {
  auto matcher = stage();
  KeyframeWords words{"robot_b", 3, 0, model_->vocabulary.hash(), {1, 2, 3}, 3};
  EXPECT_TRUE(matcher.onTeammateWords(words).refused.empty());
  words.robot = "robot_a";  // a bridge loop
  auto out = matcher.onTeammateWords(words);
  ASSERT_EQ(out.refused.size(), 1U);
  EXPECT_EQ(out.refused.front().kind, "features (own)");
  EXPECT_TRUE(out.correspondences.empty());
  words.robot = "robot_b";
  words.vocabulary_hash = "another";
  out = matcher.onTeammateWords(words);
  ASSERT_EQ(out.refused.size(), 1U);
  EXPECT_EQ(out.refused.front().kind, "features (other vocabulary)");
  out = matcher.onTeammateScan("robot_a", 1, 0, scans_->at(2.0, 1), Pose3::Identity(), false);
  ASSERT_EQ(out.refused.size(), 1U);
  EXPECT_EQ(out.refused.front().kind, "scans (own)");
  EXPECT_EQ(matcher.matcher().keptScans(), 0U);
}

}  // namespace
}  // namespace ccir_mapping::core::place_recognition
