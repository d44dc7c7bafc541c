// The Matcher's core: model files (round trip, errors that name the file), c_k correspondences,
// the temporal exclusion window, teammate queries that never become places, both methods.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "ccir_mapping/core/place_recognition/place_matcher.h"

namespace ccir_mapping::core::place_recognition {
namespace {

namespace fs = std::filesystem;

constexpr int kWords = 40;

/// Random unit-sum descriptors around `kWords` centres.
std::vector<features::SpinImage> blobDescriptors(int per_word, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  std::vector<features::SpinImage> centres(kWords);
  for (auto& c : centres) {
    for (float& v : c) v = u(rng) < 0.1F ? 1.0F : 0.0F;
  }
  std::vector<features::SpinImage> descriptors;
  for (int i = 0; i < per_word; ++i) {
    for (const auto& c : centres) {
      features::SpinImage d = c;
      float sum = 0.0F;
      for (float& v : d) sum += (v += 0.02F * u(rng));
      for (float& v : d) v /= sum;
      descriptors.push_back(d);
    }
  }
  return descriptors;
}

std::shared_ptr<const PlaceModel> smallModel() {
  const auto training = blobDescriptors(20, 1);
  Vocabulary vocabulary = Vocabulary::train(training, kWords);
  std::mt19937 rng(2);
  std::vector<WordSet> sets;
  for (int k = 0; k < 60; ++k) {
    std::vector<features::SpinImage> keyframe;
    for (int i = 0; i < 12; ++i) keyframe.push_back(training[rng() % training.size()]);
    sets.push_back(vocabulary.quantize(keyframe));
  }
  ChowLiuTree tree = ChowLiuTree::learn(sets, vocabulary.size());
  return std::make_shared<const PlaceModel>(
      PlaceModel{std::move(vocabulary), std::move(tree), sets, features::FeatureParams{}});
}

/// A place: a flat random cloud and 40 keypoints at random positions with the given descriptors.
struct Scene {
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  features::LocalFeatures features;
};

Scene scene(const std::vector<features::SpinImage>& descriptors, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-10.0F, 10.0F);
  Scene s;
  for (int i = 0; i < 3000; ++i) {
    pcl::PointXYZINormal p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = 0.2F * u(rng);
    // Half floor, half walls (the overlap test looks at walls only).
    (i % 2 ? p.normal_x : p.normal_z) = 1.0F;
    s.cloud.push_back(p);
  }
  for (const auto& d : descriptors) {
    s.features.keypoints.emplace_back(u(rng), u(rng), u(rng));
    s.features.descriptors.push_back(d);
  }
  return s;
}

class PlaceMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = smallModel();
    const auto pool = blobDescriptors(1, 7);
    for (unsigned k = 0; k < 3; ++k) {
      // Distinct places: different halves of the words, different geometry.
      std::vector<features::SpinImage> descriptors;
      for (std::size_t i = k * 13; i < k * 13 + 20 && i < pool.size(); ++i) {
        descriptors.push_back(pool[i]);
      }
      scenes_.push_back(scene(descriptors, 10 + k));
    }
  }

  /// Without a verification budget: a teammate query verifies its candidates at once.
  static MatcherParams atOnce() {
    MatcherParams params;
    params.search.prior_free_verifications_per_s = 0.0;
    return params;
  }

  DescribedKeyframe keyframe(const PlaceMatcher& matcher, KeyframeId id, double stamp_s,
                             int scene) const {
    const Scene& s = scenes_[static_cast<std::size_t>(scene)];
    return matcher.describe(id, fromSeconds(stamp_s), s.cloud, s.features,
                            Eigen::Vector3f::UnitZ());
  }

  std::shared_ptr<const PlaceModel> model_;
  std::vector<Scene> scenes_;
};

TEST_F(PlaceMatcherTest, OwnLoopsOnlyBeyondTheExclusionWindow) {
  MatcherParams params;
  params.loop_exclusion_s = 30.0;
  PlaceMatcher matcher(params, model_);
  EXPECT_TRUE(matcher.addOwn(keyframe(matcher, 0, 0.0, 0)).empty());
  EXPECT_TRUE(matcher.addOwn(keyframe(matcher, 1, 5.0, 1)).empty());
  // The first place again, 10 s later: too recent to be a loop.
  EXPECT_TRUE(matcher.addOwn(keyframe(matcher, 2, 10.0, 0)).empty());
  // And 40 s later: keyframes 0 and 2 qualify and verify (same geometry); 1 is another place.
  const auto candidates = matcher.addOwn(keyframe(matcher, 3, 40.0, 0));
  const MatchCandidate* best = bestAccepted(candidates);
  ASSERT_NE(best, nullptr);
  EXPECT_TRUE(best->keyframe == 0 || best->keyframe == 2) << best->keyframe;
  EXPECT_LT(best->verification.relative.translation().norm(), 0.05);
  EXPECT_GE(best->correspondences, params.min_correspondences);
  for (const auto& c : candidates) {
    if (c.keyframe == 1) {
      EXPECT_FALSE(c.verification.accepted);
    }
  }
  EXPECT_EQ(matcher.places(), 4U);
  // As a loop closure: from the older keyframe (the place) to the new one.
  const auto loop = matcher.loopClosure("robot_a", *best, "robot_a", 3);
  EXPECT_EQ(loop.robot_from, "robot_a");
  EXPECT_EQ(loop.keyframe_from, best->keyframe);
  EXPECT_EQ(loop.robot_to, "robot_a");
  EXPECT_EQ(loop.keyframe_to, 3U);
  EXPECT_TRUE(loop.relative.isApprox(best->verification.relative));
  EXPECT_EQ(loop.covariance, best->verification.covariance);
  EXPECT_FALSE(loop.odom_pose_from) << "described without odometry";
  EXPECT_EQ(loop.match_score, best->score);
  EXPECT_EQ(loop.new_place_probability, best->new_place_probability);
  EXPECT_GE(best->new_place_probability, 0.0) << "FAB-MAP reports p(new)";
  EXPECT_LT(best->new_place_probability, 1.0);
  EXPECT_EQ(loop.inliers, best->verification.inliers);
  EXPECT_EQ(loop.fitness_m2, best->verification.fitness_m2);
  EXPECT_EQ(loop.method, "fabmap");
}

TEST_F(PlaceMatcherTest, OwnLoopsAreSearchedNearestFirstWhereOdometryPutsThem) {
  MatcherParams params;
  params.search.gated_candidates = 2;
  PlaceMatcher matcher(params, model_);
  auto at = [&](KeyframeId id, double stamp_s, double x, double path_m) {
    DescribedKeyframe k = keyframe(matcher, id, stamp_s, 0);  // all look alike
    k.odom_pose = Pose3(Eigen::Translation3d(x, 0.0, 0.0));
    k.path_m = path_m;
    return k;
  };
  for (KeyframeId id = 0; id < 5; ++id) matcher.addOwn(at(id, double(id), double(id), double(id)));
  matcher.addOwn(at(5, 5.0, 200.0, 200.0));  // a look-alike far from here
  // Back near the start after 400 m: the gate (15 m + 1 m + 0.1 x path, at most 60 m) holds the
  // first five places, and the two nearest where odometry puts the keyframe are verified.
  const auto candidates = matcher.addOwn(at(6, 100.0, 0.2, 400.0));
  ASSERT_EQ(candidates.size(), 2U);
  std::vector<KeyframeId> verified{candidates[0].keyframe, candidates[1].keyframe};
  std::sort(verified.begin(), verified.end());
  EXPECT_EQ(verified, (std::vector<KeyframeId>{0, 1}));
  ASSERT_NE(bestAccepted(candidates), nullptr);

  // Without the gate (own_loop_gate_m_per_m 0) every place is a candidate, the look-alike too.
  params.own_loop_gate_m_per_m = 0.0;
  PlaceMatcher ungated(params, model_);
  for (KeyframeId id = 0; id < 5; ++id) ungated.addOwn(at(id, double(id), double(id), double(id)));
  ungated.addOwn(at(5, 5.0, 200.0, 200.0));
  EXPECT_EQ(ungated.addOwn(at(6, 100.0, 0.2, 400.0)).size(), 6U);
}

TEST_F(PlaceMatcherTest, TeammateCandidatesWaitForTheBudgetAndTheirClosuresGateTheNext) {
  MatcherParams params;
  params.search.prior_free_verifications_per_s = 1.0;
  PlaceMatcher matcher(params, model_);
  auto own = [&](KeyframeId id, double stamp_s, int scene, double x) {
    DescribedKeyframe k = keyframe(matcher, id, stamp_s, scene);
    k.odom_pose = Pose3(Eigen::Translation3d(x, 0.0, 0.0));
    k.path_m = x;
    return k;
  };
  auto theirs = [&](KeyframeId id, double stamp_s) {
    DescribedKeyframe k = keyframe(matcher, id, stamp_s, 1);
    k.odom_pose = Pose3(Eigen::Translation3d(-2.0, 0.0, 0.0));  // in robot_b's frame
    return k;
  };
  matcher.addOwn(own(0, 0.0, 1, 0.0));
  matcher.addOwn(own(1, 1.0, 2, 5.0));
  // robot_b's frame is not anchored yet: its scan's candidates wait for the budget.
  EXPECT_TRUE(matcher.matchTeammate("robot_b", theirs(7, 2.0)).empty());
  EXPECT_EQ(matcher.queued(), 2U) << "both own places share words with it";
  matcher.keepTeammateScan("robot_b", theirs(7, 2.0));
  EXPECT_TRUE(matcher.verifyQueued().empty()) << "no mission time has passed yet";
  matcher.addOwn(own(2, 4.0, 0, 10.0));  // 2 s later, a budget of 1 verification
  const auto released = matcher.verifyQueued();
  ASSERT_EQ(released.size(), 1U);
  EXPECT_EQ(released[0].own, 0U) << "the best-scored pair first";
  EXPECT_EQ(released[0].candidate.robot, "robot_b");
  EXPECT_EQ(released[0].candidate.keyframe, 7U);
  EXPECT_DOUBLE_EQ(released[0].waited_s, 2.0) << "queued at 2 s, verified at 4 s";
  ASSERT_TRUE(released[0].candidate.verification.accepted);
  EXPECT_EQ(matcher.queued(), 1U);
  // That closure anchors robot_b's frame: its next scan there is verified at once.
  const auto candidates = matcher.matchTeammate("robot_b", theirs(8, 5.0));
  const MatchCandidate* best = bestAccepted(candidates);
  ASSERT_NE(best, nullptr);
  EXPECT_EQ(best->keyframe, 0U);
}

TEST_F(PlaceMatcherTest, AClosureATeammateFoundAnchorsItsFrameToo) {
  PlaceMatcher matcher(MatcherParams{}, model_);
  DescribedKeyframe place = keyframe(matcher, 0, 0.0, 1);
  place.odom_pose = Pose3::Identity();
  matcher.addOwn(place);
  auto theirs = [&](KeyframeId id) {
    DescribedKeyframe k = keyframe(matcher, id, 2.0, 1);
    k.odom_pose = Pose3(Eigen::Translation3d(-2.0, 0.0, 0.0));
    return k;
  };
  pose_graph::LoopClosureData loop;
  loop.robot_from = "robot_c";  // robot_c's keyframe 7 is where this robot's keyframe 0 is
  loop.keyframe_from = 7;
  loop.robot_to = "robot_a";
  loop.keyframe_to = 0;
  loop.odom_pose_from = Pose3(Eigen::Translation3d(-2.0, 0.0, 0.0));
  matcher.addTeammateClosure("robot_b", loop);  // not with this robot: ignored
  pose_graph::LoopClosureData broken = loop;
  broken.robot_from = "robot_b";
  broken.odom_pose_from->translation().x() = std::nan("");
  matcher.addTeammateClosure("robot_a", broken);  // not a usable pose: ignored
  EXPECT_EQ(matcher.anchors("robot_b"), 0U);
  matcher.addTeammateClosure("robot_a", loop);
  EXPECT_TRUE(matcher.matchTeammate("robot_b", theirs(8)).empty()) << "robot_b is not anchored";
  EXPECT_EQ(matcher.anchors("robot_c"), 1U);
  const MatchCandidate* best = bestAccepted(matcher.matchTeammate("robot_c", theirs(9)));
  ASSERT_NE(best, nullptr) << "robot_c's frame is: verified at once";
  EXPECT_EQ(best->keyframe, 0U);
}

TEST_F(PlaceMatcherTest, ScanContextFindsOwnLoopsAndReportsItsMethod) {
  MatcherParams params;
  params.method = MatchMethod::kScanContext;
  params.loop_exclusion_s = 30.0;
  PlaceMatcher matcher(params, model_);
  const DescribedKeyframe first = keyframe(matcher, 0, 0.0, 0);
  ASSERT_TRUE(first.context) << "described for Scan Context";
  EXPECT_FALSE(keyframe(PlaceMatcher(MatcherParams{}, model_), 0, 0.0, 0).context)
      << "only with that method";
  EXPECT_TRUE(matcher.addOwn(first).empty());
  EXPECT_TRUE(matcher.addOwn(keyframe(matcher, 1, 5.0, 1)).empty());
  const auto candidates = matcher.addOwn(keyframe(matcher, 2, 40.0, 0));
  ASSERT_EQ(candidates.size(), 2U) << "both places older than the window";
  EXPECT_EQ(candidates[0].keyframe, 0U) << "the same scene ranks first";
  EXPECT_NEAR(candidates[0].score, 1.0, 1e-6);
  EXPECT_LT(candidates[1].score, candidates[0].score);
  const MatchCandidate* best = bestAccepted(candidates);
  ASSERT_NE(best, nullptr);
  EXPECT_EQ(best->keyframe, 0U);
  EXPECT_EQ(matcher.loopClosure("robot_a", *best, "robot_a", 2).method, "scan_context");
  EXPECT_EQ(best->new_place_probability, -1.0);
}

/// A room seen from its centre: floor, four walls 3 m high and pillars, each point with its
/// surface normal; the same room seen by a sensor at `sensor` (the cloud in that frame).
pcl::PointCloud<pcl::PointXYZINormal> room(const std::vector<Eigen::Vector2f>& pillars,
                                           const Eigen::Isometry3f& sensor, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  auto add = [&](const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
    const Eigen::Vector3f q = sensor.inverse() * p;
    const Eigen::Vector3f m = sensor.linear().transpose() * n;
    pcl::PointXYZINormal point;
    point.getVector3fMap() = q;
    point.getNormalVector3fMap() = m;
    cloud.push_back(point);
  };
  const float hx = 12.0F, hy = 7.0F;
  for (int i = 0; i < 3000; ++i) {
    add({(2 * u(rng) - 1) * hx, (2 * u(rng) - 1) * hy, -1.0F}, Eigen::Vector3f::UnitZ());
    const float side = u(rng), t = 2 * u(rng) - 1, z = -1.0F + 3.0F * u(rng);
    if (side < 0.25F)
      add({hx, t * hy, z}, -Eigen::Vector3f::UnitX());
    else if (side < 0.5F)
      add({-hx, t * hy, z}, Eigen::Vector3f::UnitX());
    else if (side < 0.75F)
      add({t * hx, hy, z}, -Eigen::Vector3f::UnitY());
    else
      add({t * hx, -hy, z}, Eigen::Vector3f::UnitY());
  }
  for (const auto& c : pillars) {
    for (int i = 0; i < 600; ++i) {
      const float a = 2.0F * float(M_PI) * u(rng);
      const Eigen::Vector3f n(std::cos(a), std::sin(a), 0.0F);
      add(Eigen::Vector3f(c.x(), c.y(), -1.0F + 3.0F * u(rng)) + 0.6F * n, n);
    }
  }
  return cloud;
}

TEST_F(PlaceMatcherTest, HgmmRegistersMixturesAndVerifiesFromTheirTransform) {
  const std::vector<Eigen::Vector2f> layout_a{{4.0F, 2.0F}, {-6.0F, -3.0F}, {-1.0F, 4.0F}};
  const std::vector<Eigen::Vector2f> layout_b{{-4.0F, 3.0F}, {7.0F, -2.0F}};
  // The teammate sees room A's points (seed 1: a fresh sample of this synthetic room is too
  // sparse for the walls' 0.1 m overlap test) from 0.5 m away, turned 30 degrees.
  Eigen::Isometry3f seen_from = Eigen::Isometry3f::Identity();
  seen_from.translate(Eigen::Vector3f(0.5F, -0.3F, 0.0F));
  seen_from.rotate(Eigen::AngleAxisf(float(M_PI) / 6.0F, Eigen::Vector3f::UnitZ()));
  const Eigen::Isometry3f origin = Eigen::Isometry3f::Identity();
  for (const MixtureCandidates from : {MixtureCandidates::kScanContext, MixtureCandidates::kAll}) {
    SCOPED_TRACE(toString(from));
    MatcherParams params = atOnce();
    params.method = MatchMethod::kHgmm;
    params.hgmm.candidates = from;
    PlaceMatcher matcher(params, model_);
    const features::LocalFeatures none;
    auto describe = [&](KeyframeId id, const pcl::PointCloud<pcl::PointXYZINormal>& cloud) {
      return matcher.describe(id, fromSeconds(0.0), cloud, none, Eigen::Vector3f::UnitZ());
    };
    DescribedKeyframe a = describe(0, room(layout_a, origin, 1));
    ASSERT_TRUE(a.mixture && a.context) << "described with a mixture and Scan Context";
    EXPECT_GT(a.mixture->size(), 8U) << "deeper than the root";
    EXPECT_FALSE(keyframe(PlaceMatcher(MatcherParams{}, model_), 0, 0.0, 0).mixture)
        << "only with that method";
    matcher.addOwn(std::move(a));
    matcher.addOwn(describe(1, room(layout_b, origin, 2)));

    const auto candidates =
        matcher.matchTeammate("robot_b", describe(7, room(layout_a, seen_from, 1)));
    const MatchCandidate* best = bestAccepted(candidates);
    ASSERT_NE(best, nullptr);
    EXPECT_EQ(best->keyframe, 0U);
    EXPECT_GT(best->score, params.hgmm.registration.min_similarity);
    EXPECT_LE(best->score, 1.0);
    EXPECT_EQ(best->verification.inliers, 0) << "no descriptors compared";
    // The teammate's keyframe ("to") in the place's frame ("from") is where it was seen from.
    const Pose3 error = seen_from.cast<double>().inverse() * best->verification.relative;
    EXPECT_LT(error.translation().norm(), 0.05);
    EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle(), 1.0 * M_PI / 180.0);
    for (const auto& c : candidates) {
      if (c.keyframe == 1) {
        EXPECT_FALSE(c.verification.accepted) << "the other room";
      }
    }
    EXPECT_EQ(matcher.loopClosure("robot_a", *best, "robot_b", 7).method, "hgmm");
  }
}

TEST_F(PlaceMatcherTest, OwnKeyframesCarryTheirOdometryAndPathLength) {
  PlaceMatcher matcher(MatcherParams{}, model_);
  const Scene& s = scenes_[0];
  matcher.addOwnTravel(1.5);
  matcher.addOwnTravel(2.0);
  const Pose3 pose(Eigen::Translation3d(3.0, 1.0, 0.0));
  const DescribedKeyframe k = matcher.describeOwn(5, fromSeconds(2.0), s.cloud, pose);
  EXPECT_EQ(k.id, 5U);
  EXPECT_EQ(k.stamp, fromSeconds(2.0));
  ASSERT_TRUE(k.odom_pose);
  EXPECT_TRUE(k.odom_pose->isApprox(pose));
  EXPECT_DOUBLE_EQ(k.path_m, 3.5);
  // A teammate's carries its odometry pose, not this robot's path.
  const DescribedKeyframe t = matcher.describeTeammate(9, fromSeconds(2.0), s.cloud, pose);
  ASSERT_TRUE(t.odom_pose);
  EXPECT_TRUE(t.odom_pose->isApprox(pose));
  EXPECT_DOUBLE_EQ(t.path_m, 0.0);
  EXPECT_EQ(t.words, k.words);
}

TEST_F(PlaceMatcherTest, ATeammatesWordSetMustShareTheVocabularyAndBeWellFormed) {
  PlaceMatcher matcher(MatcherParams{}, model_);
  const std::string& hash = matcher.model().vocabulary.hash();
  const auto size = static_cast<std::uint32_t>(matcher.model().vocabulary.size());
  EXPECT_FALSE(matcher.wordsProblem(hash, {0, 3, size - 1}));
  EXPECT_FALSE(matcher.wordsProblem(hash, {}));
  const auto other = matcher.wordsProblem("0123abcd", {0, 3});
  ASSERT_TRUE(other);
  EXPECT_EQ(other->kind, "other vocabulary");
  EXPECT_EQ(other->text.rfind("vocabulary 0123abcd, this robot uses " + hash, 0), 0U);
  for (const WordSet& bad : {WordSet{3, 0}, WordSet{2, 2}, WordSet{0, size}}) {
    const auto problem = matcher.wordsProblem(hash, bad);
    ASSERT_TRUE(problem);
    EXPECT_EQ(problem->kind, "malformed words");
    EXPECT_EQ(problem->text, "word ids are not sorted, unique and below " + std::to_string(size));
  }
}

TEST_F(PlaceMatcherTest, TeammateQueriesSeeEveryPlaceAndAreNotKept) {
  for (const MatchMethod method : {MatchMethod::kFabmap, MatchMethod::kHistogram}) {
    SCOPED_TRACE(toString(method));
    MatcherParams params = atOnce();
    params.method = method;
    PlaceMatcher matcher(params, model_);
    matcher.addOwn(keyframe(matcher, 0, 0.0, 0));
    matcher.addOwn(keyframe(matcher, 1, 1.0, 1));
    // A teammate at the same instant: no exclusion window for teammates.
    const auto candidates = matcher.matchTeammate("robot_b", keyframe(matcher, 7, 1.0, 1));
    const MatchCandidate* best = bestAccepted(candidates);
    ASSERT_NE(best, nullptr);
    EXPECT_EQ(best->keyframe, 1U);
    EXPECT_EQ(matcher.places(), 2U);
    // From the own place to the teammate's keyframe, with its odometry pose for a third robot.
    auto loop = matcher.loopClosure("robot_a", *best, "robot_b", 7);
    EXPECT_EQ(loop.robot_from, "robot_a");
    EXPECT_EQ(loop.keyframe_from, 1U);
    EXPECT_EQ(loop.robot_to, "robot_b");
    EXPECT_EQ(loop.keyframe_to, 7U);
    EXPECT_FALSE(loop.odom_pose_to);
    loop = matcher.loopClosure("robot_a", *best, "robot_b", 7,
                               Pose3(Eigen::Translation3d(0.0, 3.0, 0.0)));
    ASSERT_TRUE(loop.odom_pose_to);
    EXPECT_DOUBLE_EQ(loop.odom_pose_to->translation().y(), 3.0);
    EXPECT_TRUE(bestAccepted(matcher.matchTeammate("robot_b", keyframe(matcher, 8, 1.0, 2))) ==
                nullptr);
  }
}

TEST_F(PlaceMatcherTest, OwnKeyframesMeetTeammateScansKeptBeforeThem) {
  PlaceMatcher matcher(atOnce(), model_);
  matcher.addOwn(keyframe(matcher, 0, 0.0, 0));
  // robot_b scanned place 1 before this robot got there: no match yet, the scan is kept.
  DescribedKeyframe theirs = keyframe(matcher, 42, 1.0, 1);
  theirs.odom_pose = Pose3(Eigen::Translation3d(-2.0, 0.0, 0.0));  // in robot_b's frame
  EXPECT_EQ(bestAccepted(matcher.matchTeammate("robot_b", theirs)), nullptr);
  matcher.keepTeammateScan("robot_b", theirs);
  EXPECT_EQ(matcher.keptScans(), 1U);
  EXPECT_EQ(matcher.places(), 1U);
  // This robot arrives at place 1: the kept scan is found, the query being "from".
  const auto candidates = matcher.matchKeptScans(keyframe(matcher, 1, 2.0, 1));
  const MatchCandidate* best = bestAccepted(candidates);
  ASSERT_NE(best, nullptr);
  EXPECT_EQ(best->robot, "robot_b");
  EXPECT_EQ(best->keyframe, 42U);
  EXPECT_LT(best->verification.relative.translation().norm(), 0.05);
  // From the own query to the teammate's kept scan; with its odometry pose once it is a place.
  auto loop = matcher.loopClosure("robot_a", *best, "robot_a", 1);
  EXPECT_EQ(loop.robot_from, "robot_a");
  EXPECT_EQ(loop.keyframe_from, 1U);
  EXPECT_EQ(loop.robot_to, "robot_b");
  EXPECT_EQ(loop.keyframe_to, 42U);
  ASSERT_TRUE(loop.odom_pose_to) << "the kept scan's, for a third robot";
  EXPECT_DOUBLE_EQ(loop.odom_pose_to->translation().x(), -2.0);
  auto placed = keyframe(matcher, 1, 2.0, 1);
  placed.odom_pose = Pose3(Eigen::Translation3d(4.0, 0.0, 0.0));
  matcher.addOwn(placed);
  loop = matcher.loopClosure("robot_a", *best, "robot_a", 1);
  ASSERT_TRUE(loop.odom_pose_from);
  EXPECT_DOUBLE_EQ(loop.odom_pose_from->translation().x(), 4.0);
  // Own places carry no robot name, and a kept scan never answers for an own loop.
  for (const auto& c : matcher.addOwn(keyframe(matcher, 2, 100.0, 0))) {
    EXPECT_TRUE(c.robot.empty());
    EXPECT_NE(c.keyframe, 42U);
  }
  EXPECT_EQ(bestAccepted(matcher.matchKeptScans(keyframe(matcher, 3, 101.0, 2))), nullptr);
}

TEST_F(PlaceMatcherTest, PlacesCompactedAndMadeReadyAgainVerifyAsBefore) {
  // The same own and teammate queries with every place ready, and with one place ready (the
  // others compacted, completed again when ranked): the same candidates and figures.
  std::vector<std::vector<MatchCandidate>> results[2];
  for (const int complete : {100, 1}) {
    MatcherParams params = atOnce();
    params.complete_places = complete;
    PlaceMatcher matcher(params, model_);
    auto& out = results[complete == 1];
    for (KeyframeId id = 0; id < 6; ++id) {
      out.push_back(matcher.addOwn(keyframe(matcher, id, 40.0 * double(id), int(id % 3))));
    }
    matcher.keepTeammateScan("robot_b", keyframe(matcher, 42, 1.0, 1));
    out.push_back(matcher.matchTeammate("robot_b", keyframe(matcher, 7, 300.0, 2)));
    out.push_back(matcher.matchKeptScans(keyframe(matcher, 8, 301.0, 1)));
  }
  ASSERT_EQ(results[0].size(), results[1].size());
  int accepted = 0;
  for (std::size_t q = 0; q < results[0].size(); ++q) {
    ASSERT_EQ(results[0][q].size(), results[1][q].size()) << "query " << q;
    for (std::size_t c = 0; c < results[0][q].size(); ++c) {
      const auto& a = results[0][q][c].verification;
      const auto& b = results[1][q][c].verification;
      EXPECT_EQ(results[0][q][c].keyframe, results[1][q][c].keyframe);
      EXPECT_EQ(a.accepted, b.accepted);
      EXPECT_EQ(a.inliers, b.inliers);
      EXPECT_EQ(a.fitness_m2, b.fitness_m2);
      EXPECT_TRUE(a.relative.isApprox(b.relative, 1e-12));
      accepted += a.accepted;
    }
  }
  EXPECT_GT(accepted, 3) << "the scenario must verify something";
}

TEST_F(PlaceMatcherTest, CorrespondencesCountSharedWordsAboveTheMinimum) {
  MatcherParams params;
  params.min_correspondences = 3;
  PlaceMatcher matcher(params, model_);
  std::vector<DescribedKeyframe> places;
  for (int k = 0; k < 3; ++k) {
    places.push_back(keyframe(matcher, static_cast<KeyframeId>(k), k, k));
    matcher.addOwn(places.back());
  }
  const WordSet& query = places[0].words;
  const auto result = matcher.correspondences(query);
  ASSERT_FALSE(result.empty());
  EXPECT_EQ(result.front().first, 0U);
  EXPECT_EQ(result.front().second, static_cast<int>(query.size()));
  for (std::size_t i = 0; i < result.size(); ++i) {
    const WordSet& words = places[result[i].first].words;
    WordSet shared;
    std::set_intersection(query.begin(), query.end(), words.begin(), words.end(),
                          std::back_inserter(shared));
    EXPECT_EQ(result[i].second, static_cast<int>(shared.size()));
    EXPECT_GE(result[i].second, 3);
    if (i > 0) {
      EXPECT_LE(result[i].second, result[i - 1].second);
    }
  }
  EXPECT_TRUE(matcher.correspondences({}).empty());
}

TEST_F(PlaceMatcherTest, NewOwnKeyframesGetTheirCorrespondencesWithKeptTeammateWords) {
  MatcherParams params;
  params.min_correspondences = 3;
  PlaceMatcher matcher(params, model_);
  // robot_b sent the word sets of its keyframes 5 (shares 4 words), 6 (shares 6) and 7 (2).
  const WordSet own = {1, 3, 5, 7, 9, 11, 13};
  matcher.keepTeammateWords("robot_b", 5, {1, 2, 3, 4, 5, 7});
  matcher.keepTeammateWords("robot_b", 6, {1, 3, 5, 7, 9, 11, 12});
  matcher.keepTeammateWords("robot_b", 7, {11, 13, 100});  // 11 and 13 shared
  matcher.keepTeammateWords("robot_c", 1, {1, 3, 200});    // 2 shared: below the minimum
  const auto result = matcher.teammateCorrespondences(own);
  ASSERT_EQ(result.size(), 1U);
  EXPECT_EQ(result[0].robot, "robot_b");
  EXPECT_EQ(result[0].keyframe, 6U);
  EXPECT_EQ(result[0].count, 6);
  matcher.keepTeammateWords("robot_c", 2, {1, 3, 5, 9});
  EXPECT_EQ(matcher.teammateCorrespondences(own).size(), 2U);
  EXPECT_TRUE(matcher.teammateCorrespondences({}).empty());
}

TEST_F(PlaceMatcherTest, InvalidParametersAndMissingModelAreNamed) {
  MatcherParams params;
  params.max_candidates = 0;
  try {
    PlaceMatcher matcher(params, model_);
    FAIL() << "accepted max_candidates = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_candidates"), std::string::npos) << e.what();
  }
  EXPECT_THROW(PlaceMatcher(MatcherParams{}, nullptr), std::invalid_argument);
}

TEST(PlaceModel, RoundTripsAndNamesTheBrokenFile) {
  const auto model = smallModel();
  const fs::path dir = fs::temp_directory_path() / "ccir_place_model_test";
  fs::remove_all(dir);
  PlaceModel copy{Vocabulary(model->vocabulary.words()), model->tree, model->samples,
                  model->features};
  copy.features.drop_horizontal = preprocess::HorizontalFilter::kGround;
  copy.features.iss_non_max_radius_m = 1.25;
  copy.features.voxel_m = 0.15;
  copy.features.spin_support_m = 3.5;
  copy.features.spin_axis = features::SpinAxis::kNormal;
  copy.features.iss_min_neighbors = 7;
  copy.save(dir.string(), "note: test\n");
  const auto loaded = PlaceModel::load(dir.string());
  EXPECT_EQ(loaded->vocabulary.hash(), model->vocabulary.hash());
  EXPECT_EQ(loaded->samples, model->samples);
  EXPECT_EQ(loaded->tree.size(), model->tree.size());
  EXPECT_EQ(loaded->features.drop_horizontal, preprocess::HorizontalFilter::kGround);
  EXPECT_DOUBLE_EQ(loaded->features.iss_non_max_radius_m, 1.25);
  EXPECT_DOUBLE_EQ(loaded->features.voxel_m, 0.15);
  EXPECT_DOUBLE_EQ(loaded->features.spin_support_m, 3.5);
  EXPECT_EQ(loaded->features.spin_axis, features::SpinAxis::kNormal);
  EXPECT_EQ(loaded->features.iss_min_neighbors, 7);
  EXPECT_DOUBLE_EQ(loaded->features.normal_radius_m, features::FeatureParams{}.normal_radius_m);

  auto expectError = [&](const std::string& file) {
    try {
      PlaceModel::load(dir.string());
      ADD_FAILURE() << "loaded a model with a broken " << file;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
  };
  std::ofstream(dir / "samples.txt")
      << "# ccir_mapping new-place samples 1 0000000000000000\n1 2\n";
  expectError("samples.txt");
  copy.save(dir.string(), "");
  std::ofstream(dir / "model.yaml") << "vocabulary_hash: " << model->vocabulary.hash() << "\n";
  expectError("model.yaml");
  fs::remove(dir / "chow_liu_tree.txt");
  expectError("chow_liu_tree.txt");
  fs::remove_all(dir);
  expectError(dir.string());
}

}  // namespace
}  // namespace ccir_mapping::core::place_recognition
