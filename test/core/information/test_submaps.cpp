// Submaps (docs/mapping.md, "Submaps"): scans grouped per robot, moved as blocks when their poses
// move and integrated again only when they bend; the map recomputed only where moved submaps
// were and are, each voxel once however many submaps overlap it; moving equals inserting the
// scans again at the new poses within one voxel.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include <pcl/common/transforms.h>

#include "ccir_mapping/core/information/keyframe_map.h"
#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/submap_set.h"
#include "room_scan.h"

namespace ccir_mapping::core::information {
namespace {

/// The room as a sensor at `pose` (inside it) sees it, in the sensor frame.
std::shared_ptr<const Cloud> scanFrom(const Pose3& pose) {
  auto cloud = std::make_shared<Cloud>();
  pcl::transformPointCloud(roomScan(pose.translation()), *cloud,
                           pose.inverse().matrix().cast<float>());
  return cloud;
}

using KeyTuple = std::tuple<int, int, int>;

std::set<KeyTuple> occupied(const OccupancyMap& map) {
  std::set<KeyTuple> keys;
  map.voxels().forEach([&](const octomap::OcTreeKey& key, float log_odds) {
    if (log_odds >= map.grid().getOccupancyThresLog()) keys.emplace(key[0], key[1], key[2]);
  });
  return keys;
}

/// The share of a's occupied voxels with an occupied voxel of b at most one voxel away.
double withinOneVoxel(const OccupancyMap& a, const OccupancyMap& b) {
  const auto in_a = occupied(a);
  const auto in_b = occupied(b);
  std::size_t near = 0;
  for (const auto& [x, y, z] : in_a) {
    bool found = false;
    for (int dx = -1; dx <= 1 && !found; ++dx)
      for (int dy = -1; dy <= 1 && !found; ++dy)
        for (int dz = -1; dz <= 1 && !found; ++dz) found = in_b.count({x + dx, y + dy, z + dz});
    near += found;
  }
  return in_a.empty() ? 0.0 : static_cast<double>(near) / static_cast<double>(in_a.size());
}

double occupiedCount(const MapperStage& stage) {
  return static_cast<double>(
      stage.map()->read([](const OccupancyMap& map) { return map.occupiedCentres().size(); }));
}

TEST(OccupancyMap, AssignSetsOrForgetsVoxelsWithTheEntropyBoxFollowing) {
  OccupancyMap map(params());
  map.insert(*scanFrom(at(0, 0)), at(0, 0));
  std::vector<octomap::OcTreeKey> keys;
  map.voxels().forEach([&](const octomap::OcTreeKey& key, float) { keys.push_back(key); });
  ASSERT_GE(keys.size(), 2U);
  const octomap::OcTreeKey known = keys[0];
  const octomap::OcTreeKey forgotten = keys[1];
  octomap::OcTreeKey unknown;
  ASSERT_TRUE(map.grid().coordToKeyChecked(octomap::point3d(30, 30, 0), unknown));
  map.assign({{known, 2.0F}, {forgotten, std::nullopt}, {unknown, -99.0F}});
  EXPECT_NEAR(*map.voxels().find(known), 2.0, 1e-6);
  EXPECT_EQ(map.voxels().find(forgotten), nullptr);
  EXPECT_NEAR(*map.voxels().find(unknown), map.grid().getClampingThresMinLog(), 1e-6) << "clamped";
  EXPECT_EQ(map.voxels().voxels(), keys.size());
  const Box box{params().entropyBoxMin(), params().entropyBoxMax()};
  EXPECT_NEAR(map.boxEntropyBits(), map.entropyBits(box), 1e-9 * map.boxEntropyBits());
  EXPECT_NEAR(map.boxKnownVolumeM3(), map.knownVolumeM3(box), 1e-9);
}

TEST(OccupancyMap, EveryVoxelHoldsWhatWasLastAssignedOrInsertedInWhateverOrder) {
  // Keys out of the tree's order, voxels forgotten between (bricks released) and new ones must
  // not lead the map's bricks astray. A plain map of key -> log-odds is the reference.
  OccupancyMap map(params());
  std::map<std::tuple<int, int, int>, float> reference;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> near(32760, 32800);  // a few bricks: paths shared often
  std::uniform_real_distribution<float> value(-4.0F, 4.0F);
  const float hit = map.grid().getProbHitLog();
  const float lo = map.grid().getClampingThresMinLog();
  const float hi = map.grid().getClampingThresMaxLog();
  for (int round = 0; round < 40; ++round) {
    std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>> assigned;
    ScanUpdate hits;
    for (int i = 0; i < 200; ++i) {
      const octomap::OcTreeKey key(near(rng), near(rng), near(rng));
      const std::tuple<int, int, int> at{key[0], key[1], key[2]};
      if (i % 3 == 0) {
        hits.occupied.push_back(key);
        continue;
      }
      const std::optional<float> v = i % 5 == 0 ? std::nullopt : std::optional<float>(value(rng));
      assigned.emplace_back(key, v);
    }
    map.assign(assigned);
    for (const auto& [key, v] : assigned) {
      if (v) {
        reference[{key[0], key[1], key[2]}] = std::clamp(*v, lo, hi);
      } else {
        reference.erase({key[0], key[1], key[2]});
      }
    }
    std::sort(hits.occupied.begin(), hits.occupied.end(), [](const auto& a, const auto& b) {
      return a[0] != b[0] ? a[0] < b[0] : a[1] < b[1];
    });
    hits.occupied.erase(std::unique(hits.occupied.begin(), hits.occupied.end()),
                        hits.occupied.end());
    map.insert(hits);
    for (const auto& key : hits.occupied) {
      auto [it, fresh] = reference.try_emplace({key[0], key[1], key[2]}, 0.0F);
      it->second = std::clamp(it->second + hit, lo, hi);
    }
  }
  EXPECT_EQ(map.voxels().voxels(), reference.size());
  for (const auto& [at, log_odds] : reference) {
    const float* found =
        map.voxels().find(octomap::OcTreeKey(std::get<0>(at), std::get<1>(at), std::get<2>(at)));
    ASSERT_NE(found, nullptr);
    ASSERT_NEAR(*found, log_odds, 1e-5);
  }
  const Box box{params().entropyBoxMin(), params().entropyBoxMax()};
  EXPECT_NEAR(map.boxEntropyBits(), map.entropyBits(box), 1e-9 * map.boxEntropyBits());
  EXPECT_NEAR(map.boxKnownVolumeM3(), map.knownVolumeM3(box), 1e-9);
}

TEST(KeyframeMap, GroupsConsecutiveScansOfOneRobotIntoSubmaps) {
  MapperParams p = params();
  p.submap_scans = 2;
  KeyframeMap map(p);
  const auto cloud = scanFrom(at(0, 0));
  const SubmapId first = map.addOwn(1, cloud, at(0, 0)).submap;
  EXPECT_EQ(map.addOwn(2, cloud, at(1, 0)).submap, first);
  EXPECT_EQ(map.takeClosed(), std::vector<SubmapId>{first}) << "full";
  map.setTeamTransform("robot_b", at(0, 0));
  const auto peer = map.addPeer("robot_b", 7, cloud, at(0, 1));
  ASSERT_EQ(peer.size(), 1U);
  const SubmapId third = map.addOwn(3, cloud, at(2, 0)).submap;
  EXPECT_NE(peer[0].submap, third) << "a teammate's scans and own keyframes never share one";
  EXPECT_NE(third, first);
  EXPECT_EQ(map.addOwn(4, cloud, at(3, 0)).submap, third);
  EXPECT_EQ(map.submaps(), 3U);
  EXPECT_TRUE(map.takeClosed() == std::vector<SubmapId>{third});
}

TEST(KeyframeMap, MovesSubmapsWhoseFirstScanMovedAndIntegratesAgainThoseThatBent) {
  KeyframeMap map(params());
  const auto cloud = scanFrom(at(0, 0));
  EXPECT_TRUE(map.addOwn(1, cloud, at(0, 0)).map_from_sensor.isApprox(at(0, 0)));
  map.addOwn(2, cloud, at(2, 0));
  // The Backend moves keyframe 2 by 0.1 m: under the threshold (0.2 m).
  map.setOptimizedPoses({{1, at(0, 0)}, {2, at(2, 0.1)}});
  EXPECT_TRUE(map.takeMoves().empty());
  // A new keyframe is placed with the latest correction.
  EXPECT_TRUE(map.addOwn(3, cloud, at(4, 0)).map_from_sensor.isApprox(at(4, 0.1)));
  // A loop closure bends the submap: keyframe 2 moves 0.5 m and 2 degrees from keyframe 1.
  map.setOptimizedPoses({{2, at(2, 0.5, 2)}, {99, at(9, 9)}});
  auto moves = map.takeMoves();
  ASSERT_EQ(moves.size(), 1U);
  ASSERT_EQ(moves[0].scans.size(), 3U) << "integrated again, at the current poses";
  EXPECT_TRUE(moves[0].scans[1].map_from_sensor.isApprox(at(2, 0.5, 2)));
  EXPECT_TRUE(moves[0].delta.isApprox(Pose3::Identity()));
  EXPECT_TRUE(map.takeMoves().empty()) << "taken as where it is";
  // The whole submap shifts by 1 m: moved as a block.
  map.setOptimizedPoses({{1, at(0, 1)}, {2, at(2, 1.5, 2)}, {3, at(4, 1.1)}});
  moves = map.takeMoves();
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_TRUE(moves[0].scans.empty());
  EXPECT_TRUE(moves[0].delta.isApprox(at(0, 1)));
  // It takes no more scans: the next keyframe opens a submap of its own.
  EXPECT_NE(map.addOwn(4, cloud, at(6, 0)).submap, moves[0].id);

  // A teammate's scans wait for its frame, then are placed with it.
  EXPECT_TRUE(map.addPeer("robot_b", 7, cloud, at(1, 1)).empty());
  EXPECT_EQ(map.pendingPeerScans(), 1U);
  EXPECT_TRUE(map.holdsPeer("robot_b", 7));
  EXPECT_FALSE(map.holdsPeer("robot_c", 7));
  const auto placed = map.setTeamTransform("robot_b", at(10, 0, 90));
  ASSERT_EQ(placed.size(), 1U);
  EXPECT_TRUE(placed[0].map_from_sensor.isApprox(at(10, 0, 90) * at(1, 1)));
  EXPECT_EQ(map.addPeer("robot_b", 8, cloud, at(2, 2)).size(), 1U);
  EXPECT_TRUE(map.addPeer("robot_b", 8, cloud, at(3, 3)).empty()) << "held: not added twice";
  EXPECT_EQ(map.peerScans(), 2U);
  EXPECT_EQ(map.pendingPeerScans(), 0U);
  // The same estimate again changes nothing; a better one 1 m away moves robot_b's submap.
  map.setTeamTransform("robot_b", at(10, 0, 90));
  EXPECT_TRUE(map.takeMoves().empty());
  map.setTeamTransform("robot_b", at(11, 0, 90));
  moves = map.takeMoves();
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_EQ(moves[0].id, placed[0].submap);
  EXPECT_TRUE(moves[0].delta.isApprox(at(11, 0, 90) * at(10, 0, 90).inverse()));
}

TEST(KeyframeMap, PlacesTeammatesScansWhereTheTeamGraphPutsThem) {
  KeyframeMap map(params());
  const auto cloud = scanFrom(at(0, 0));
  // The graph's pose of keyframe 7 arrives before its scan, and wins over the transform.
  EXPECT_TRUE(map.setPeerPoses("robot_b", {{7, at(5, 5, 30)}}).empty()) << "no scan yet";
  const auto first = map.addPeer("robot_b", 7, cloud, at(1, 1));
  ASSERT_EQ(first.size(), 1U) << "placed by the graph before any team transform";
  EXPECT_TRUE(first[0].map_from_sensor.isApprox(at(5, 5, 30)));
  EXPECT_TRUE(map.addPeer("robot_b", 8, cloud, at(2, 1)).empty()) << "neither pose nor frame";
  EXPECT_EQ(map.pendingPeerScans(), 1U);
  const auto second = map.setTeamTransform("robot_b", at(10, 0));
  ASSERT_EQ(second.size(), 1U) << "keyframe 8 by the transform; 7 stays at the graph's pose";
  EXPECT_TRUE(second[0].map_from_sensor.isApprox(at(12, 1)));
  EXPECT_TRUE(map.takeMoves().empty()) << "7 did not move";
  // The graph moves 8 by 0.1 m (below the 0.2 m threshold), then 7 by 0.5 m.
  EXPECT_TRUE(map.setPeerPoses("robot_b", {{8, at(12, 1.1)}}).empty());
  EXPECT_TRUE(map.takeMoves().empty());
  map.setPeerPoses("robot_b", {{7, at(5, 5.5, 30)}});
  const auto moves = map.takeMoves();
  ASSERT_EQ(moves.size(), 1U);
  ASSERT_EQ(moves[0].scans.size(), 2U) << "8 moved relative to 7: integrated again";
  EXPECT_TRUE(moves[0].scans[0].map_from_sensor.isApprox(at(5, 5.5, 30)));
  EXPECT_TRUE(moves[0].scans[1].map_from_sensor.isApprox(at(12, 1.1)));
  EXPECT_EQ(map.peerScans(), 2U);
}

TEST(KeyframeMap, SettlesTheOldestClosedSubmapsBeyondTheWindow) {
  MapperParams p = params();
  p.submap_scans = 2;
  p.submap_window_scans = 2;
  KeyframeMap map(p);
  const auto cloud = scanFrom(at(0, 0));
  const SubmapId first = map.addOwn(1, cloud, at(0, 0)).submap;
  map.addOwn(2, cloud, at(2, 0));
  EXPECT_TRUE(map.settle().empty()) << "two placed scans fit the window";
  map.addOwn(3, cloud, at(4, 0));
  EXPECT_EQ(map.settle(), std::vector<SubmapId>{first}) << "keyframes 1 and 2";
  EXPECT_EQ(map.settledScans(), 2U);
  EXPECT_EQ(cloud.use_count(), 2) << "held by this test and keyframe 3 only";
  // A settled submap stays where it was, however far its scans move.
  map.setOptimizedPoses({{1, at(0, 1)}, {2, at(2, 3)}});
  EXPECT_TRUE(map.takeMoves().empty());
  EXPECT_EQ(map.ownKeyframes(), 3U);
}

TEST(SubmapSet, RecomputesTheMapOnlyWhereMovedSubmapsWereAndAre) {
  OccupancyMap map(params());
  SubmapSet submaps(map.grid());
  // The room seen at the origin (submap 1) and a copy of it 40 m away (submap 2).
  for (const auto& [id, pose] : {std::pair<SubmapId, Pose3>{1, at(0, 0)}, {2, at(40, 0)}}) {
    const auto update = map.computeUpdate(*scanFrom(at(0, 0)), pose);
    map.insert(update);
    submaps.add(id, update);
    submaps.close(id);
  }
  OccupancyMap origin_only(params());
  origin_only.insert(*scanFrom(at(0, 0)), at(0, 0));
  const auto voxels = submaps.apply({{2, at(1, 0), std::nullopt}});
  ASSERT_FALSE(voxels.empty());
  for (const auto& [key, log_odds] : voxels) {
    ASSERT_GT(map.grid().keyToCoord(key).x(), 30.0) << "nothing recomputed near the origin";
  }
  map.assign(voxels);
  OccupancyMap moved_only(params());
  moved_only.insert(*scanFrom(at(0, 0)), at(41, 0));
  const auto near_origin = occupied(origin_only);
  std::size_t kept = 0;
  for (const auto& key : occupied(map)) kept += near_origin.count(key);
  EXPECT_EQ(kept, near_origin.size()) << "the room at the origin as it was";
  EXPECT_EQ(occupied(map).size(), near_origin.size() + occupied(moved_only).size())
      << "the copy at 41 m, nothing left at 40 m";
  EXPECT_GT(withinOneVoxel(moved_only, map), 0.999);
}

TEST(SubmapSet, CountsTheVoxelsAMoveVisitsAMovedSubmapGatheredFromWhole) {
  OccupancyMap map(params());
  SubmapSet submaps(map.grid());
  const auto key = [](int x, int y) { return octomap::OcTreeKey(32768 + x, 32768 + y, 32768); };
  // Submap 1: 5 voxels along x; submap 2: 50, the first 5 the same.
  for (const auto& [id, length] : {std::pair<SubmapId, int>{1, 5}, {2, 50}}) {
    ScanUpdate update;
    for (int x = 0; x < length; ++x) update.free.push_back(key(x, 0));
    submaps.add(id, update);
    submaps.close(id);
  }
  const Pose3 one_voxel_y(Eigen::Translation3d(0, 0.1, 0));
  // Submap 1 a voxel along y: its 5 voxels where they were and 5 where they are (10 keys to
  // recompute), its evidence read whole (moved: 5), submap 2's among the keys (in key order,
  // unmoved), the 10 values gathered, the 10 keys.
  submaps.apply({{1, one_voxel_y, std::nullopt}});
  EXPECT_EQ(submaps.lastVisited(), 5U + 5U + 5U + 10U + 10U);
  submaps.apply({{1, Pose3::Identity(), std::nullopt}});  // back: nothing read whole
  EXPECT_EQ(submaps.lastVisited(), 5U + 5U + 10U + 10U);
  // Submap 2 moved within its voxels (still moved): from now on it is read whole.
  submaps.apply({{2, Pose3(Eigen::Translation3d(0, 0, 0.01)), std::nullopt}});
  submaps.apply({{1, one_voxel_y, std::nullopt}});
  EXPECT_EQ(submaps.lastVisited(), 5U + 5U + 5U + 50U + 10U + 10U);
}

TEST(SubmapSet, TheSettledPartHoldsEachVoxelOnceWithTheEvidenceOfEverySubmapSettled) {
  OccupancyMap map(params());
  SubmapSet submaps(map.grid());
  const auto key = [](int x) { return octomap::OcTreeKey(32768 + x, 32768, 32768); };
  // 60 submaps: each a miss on the same 5 voxels and a hit of its own, then settled; half of
  // them moved by a voxel along y first (settled where they are then).
  constexpr int kSettled = 60;
  for (int i = 0; i < kSettled; ++i) {
    const auto id = static_cast<SubmapId>(i + 1);
    ScanUpdate update;
    for (int x = 0; x < 5; ++x) update.free.push_back(key(x));
    update.occupied.push_back(key(100 + i));
    submaps.add(id, update);
    submaps.close(id);
    if (i % 2) submaps.apply({{id, Pose3(Eigen::Translation3d(0, 0.1, 0)), std::nullopt}});
    submaps.settle(id);
  }
  EXPECT_EQ(submaps.size(), 0U);
  // The 5 misses where they were and a voxel along y, and the 60 hits.
  EXPECT_EQ(submaps.voxels(), 5U + 5U + kSettled);
  // A live submap over all of those voxels: the map there is the sum of everyone's evidence.
  ScanUpdate over;
  for (int x = 0; x < 100 + kSettled; ++x) over.occupied.push_back(key(x));
  submaps.add(999, over);
  submaps.close(999);
  std::map<int, float> said;
  for (const auto& [k, log_odds] : submaps.apply({{999, Pose3::Identity(), std::nullopt}})) {
    if (k[1] == 32768 && log_odds) said[k[0] - 32768] = *log_odds;
  }
  const auto model = Submap::Model::of(map.grid());
  const float all_misses = std::max(model.min, 30 * model.miss) + model.hit;  // the unmoved half
  EXPECT_NEAR(said.at(0), std::max(model.min, all_misses), 1e-3);
  for (int i = 0; i < kSettled; i += 2) {
    EXPECT_NEAR(said.at(100 + i), std::min(model.max, 2 * model.hit), 1e-3) << i;
  }
  EXPECT_NEAR(said.at(101), model.hit, 1e-3) << "moved along y: only the live submap's hit here";
}

TEST(MapperStage, MovingSubmapsEqualsInsertingTheirScansAtTheNewPosesWithinOneVoxel) {
  MapperParams p = params();
  p.submap_scans = 3;
  MapperStage stage("robot_a", p);
  std::vector<Pose3> poses;
  for (int i = 0; i < 6; ++i) poses.push_back(at(-3.0 + i, 0.5 * (i % 2), 10.0 * i));
  for (std::size_t i = 0; i < poses.size(); ++i)
    stage.addOwn(Stamp(i + 1), scanFrom(poses[i]), poses[i]);
  // A loop closure moves the whole trajectory by 0.6 m and 4 degrees.
  const Pose3 correction = at(0.6, -0.4, 4);
  std::vector<std::pair<Stamp, Pose3>> corrected;
  OccupancyMap inserted_again(p), as_before(p);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    corrected.emplace_back(Stamp(i + 1), correction * poses[i]);
    inserted_again.insert(*scanFrom(poses[i]), correction * poses[i]);
    as_before.insert(*scanFrom(poses[i]), poses[i]);
  }
  stage.setOptimizedPoses(corrected);
  EXPECT_EQ(stage.followPoses(0.0), 2U);
  const auto stats = stage.stats();
  EXPECT_EQ(stats.submap_moves, 2U);
  EXPECT_EQ(stats.reintegrations, 0U);
  stage.map()->read([&](const OccupancyMap& map) {
    EXPECT_GT(withinOneVoxel(map, inserted_again), 0.99);
    EXPECT_GT(withinOneVoxel(inserted_again, map), 0.99);
    EXPECT_LT(withinOneVoxel(as_before, inserted_again), 0.5) << "the correction is visible";
    EXPECT_NEAR(map.boxKnownVolumeM3(), inserted_again.boxKnownVolumeM3(),
                0.03 * inserted_again.boxKnownVolumeM3());
    return 0;
  });
  EXPECT_EQ(stage.followPoses(1e6), 0U) << "nothing moved since";
}

TEST(MapperStage, WaitsInProportionToTheVoxelsItVisited) {
  MapperParams p = params();
  p.reanchor_wait_s_per_mvoxel_visited = 1000.0;  // 1 ms a voxel
  MapperStage stage("robot_a", p);
  stage.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  stage.setOptimizedPoses({{1, at(0, 1)}});
  ASSERT_EQ(stage.followPoses(100.0), 1U) << "the first waits for nothing";
  // Moving the room's scan recomputes where it was and is: some thousands of voxels.
  stage.setOptimizedPoses({{1, at(0, 2)}});
  EXPECT_EQ(stage.followPoses(102.0), 0U) << "waits";
  EXPECT_EQ(stage.stats().submap_moves, 1U);
  EXPECT_EQ(stage.followPoses(1e6), 1U) << "the move gathered meanwhile";
  EXPECT_EQ(stage.stats().submap_moves, 2U);
}

TEST(MapperStage, ASubmapWhoseScansBentIsIntegratedAgainAtTheirNewPoses) {
  MapperStage stage("robot_a", params());
  stage.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  stage.addOwn(2, scanFrom(at(2, 0)), at(2, 0));
  stage.setOptimizedPoses({{2, at(2, 0.6, 3)}});
  EXPECT_EQ(stage.followPoses(0.0), 1U);
  EXPECT_EQ(stage.stats().reintegrations, 1U);
  OccupancyMap direct(params());
  direct.insert(*scanFrom(at(0, 0)), at(0, 0));
  direct.insert(*scanFrom(at(2, 0)), at(2, 0.6, 3));
  // One submap: the same voxels with the same log-odds, but for the submap's 0.001 quantum.
  std::size_t differ = 0;
  stage.map()->read([&](const OccupancyMap& map) {
    EXPECT_EQ(map.voxels().voxels(), direct.voxels().voxels());
    direct.voxels().forEach([&](const octomap::OcTreeKey& key, float log_odds) {
      const float* found = map.voxels().find(key);
      differ += !found || std::abs(*found - log_odds) >= 1e-3;
    });
    EXPECT_NEAR(map.boxEntropyBits(), direct.boxEntropyBits(), 1e-3 * direct.boxEntropyBits());
    return 0;
  });
  EXPECT_EQ(differ, 0U);
}

TEST(MapperStage, SubmapsThatOverlapAreOneVoxelEachInTheStatistics) {
  MapperParams p = params();
  p.submap_scans = 1;
  MapperStage stage("robot_a", p);
  stage.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  stage.addOwn(2, scanFrom(at(1, 0)), at(1, 0));
  stage.setOptimizedPoses({{1, at(0, 1)}, {2, at(1, 1)}});
  EXPECT_EQ(stage.followPoses(0.0), 2U);
  OccupancyMap direct(p);
  direct.insert(*scanFrom(at(0, 0)), at(0, 1));
  direct.insert(*scanFrom(at(1, 0)), at(1, 1));
  const auto stats = stage.stats();
  EXPECT_NEAR(stats.known_volume_m3, direct.boxKnownVolumeM3(), 0.01 * direct.boxKnownVolumeM3())
      << "not the sum of the two submaps' volumes";
  EXPECT_NEAR(stats.entropy_bits, direct.boxEntropyBits(), 1e-3 * direct.boxEntropyBits());
  EXPECT_EQ(stats.submaps, 2U);
}

TEST(MapperStage, SettledSubmapsKeepTheirEvidenceWhereTheyWereWhenLiveOnesMove) {
  MapperParams p = params();
  p.submap_scans = 1;
  p.submap_window_scans = 1;
  MapperStage stage("robot_a", p);
  stage.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  stage.addOwn(2, scanFrom(at(1, 0)), at(1, 0));
  stage.followPoses(0.0);  // two live scans: more than 1.25 x the window of one, so 1 settles
  EXPECT_EQ(stage.stats().settled_scans, 1U);
  EXPECT_EQ(stage.stats().submaps, 1U);
  stage.setOptimizedPoses({{1, at(0, 1)}, {2, at(1, 1)}});
  EXPECT_EQ(stage.followPoses(0.0), 1U) << "keyframe 2 only";
  OccupancyMap expected(p);
  expected.insert(*scanFrom(at(0, 0)), at(0, 0));
  expected.insert(*scanFrom(at(1, 0)), at(1, 1));
  stage.map()->read([&](const OccupancyMap& map) {
    EXPECT_GT(withinOneVoxel(map, expected), 0.99);
    EXPECT_GT(withinOneVoxel(expected, map), 0.99);
    EXPECT_NEAR(map.boxKnownVolumeM3(), expected.boxKnownVolumeM3(),
                0.01 * expected.boxKnownVolumeM3());
    return 0;
  });
}

TEST(MapperStage, RefusesItsOwnScansAndScansItHolds) {
  MapperStage stage("robot_a", params());
  const auto cloud = scanFrom(at(0, 0));
  EXPECT_FALSE(stage.addPeer("robot_b", 7, cloud, at(1, 1)));
  EXPECT_EQ(stage.addPeer("robot_b", 7, cloud, at(1, 1)), "it is in the map already");
  EXPECT_EQ(stage.addPeer("robot_a", 8, cloud, at(1, 1)), "it is this robot's own");
  stage.setTeamTransform("robot_a", at(50, 50));  // ignored
  const auto stats = stage.stats();
  EXPECT_EQ(stats.pending_peer_scans, 1U);
  EXPECT_EQ(stats.peer_scans, 0U);
  stage.setTeamTransform("robot_b", at(0, 0));
  EXPECT_EQ(stage.stats().peer_scans, 1U);
  EXPECT_GT(stage.stats().known_volume_m3, 0.0);
}

TEST(MapperStage, SaveWritesTheMapIntoAFolderItCreatesAndOctoMapReadsItBack) {
  MapperStage stage("robot_a", params());
  stage.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  const std::string dir = ::testing::TempDir() + "map_stage_save/robot_a";
  std::filesystem::remove_all(dir);
  const std::string path = stage.save(dir);
  EXPECT_EQ(path, dir + "/map.bt");
  octomap::OcTree read(0.1);
  ASSERT_TRUE(read.readBinary(path));
  std::size_t read_occupied = 0;  // finest voxels: the file is pruned
  for (auto it = read.begin_leafs(); it != read.end_leafs(); ++it) {
    const std::size_t side = std::size_t{1} << (read.getTreeDepth() - it.getDepth());
    read_occupied += read.isNodeOccupied(*it) ? side * side * side : 0;
  }
  EXPECT_GT(occupiedCount(stage), 100);
  EXPECT_EQ(read_occupied, occupiedCount(stage));

  const std::string blocked = ::testing::TempDir() + "map_stage_save/a_file";
  std::ofstream(blocked) << "not a folder";
  EXPECT_THROW(stage.save(blocked + "/robot_a"), std::runtime_error);
  std::filesystem::remove_all(::testing::TempDir() + "map_stage_save");
}

TEST(MapperStage, AResumedStageContinuesTheSavedMapAndKeepsItWhenSubmapsMove) {
  const std::string dir = ::testing::TempDir() + "map_stage_resume/robot_a";
  std::filesystem::remove_all(dir);
  auto known = [](const MapperStage& stage) { return stage.stats().known_volume_m3; };
  MapperStage before("robot_a", params());
  before.addOwn(1, scanFrom(at(0, 0)), at(0, 0));
  before.save(dir);

  MapperStage after("robot_a", params());
  EXPECT_FALSE(after.resume(dir + "/nothing_here")) << "no saved map: nothing to resume";
  ASSERT_TRUE(after.resume(dir));
  EXPECT_EQ(occupiedCount(after), occupiedCount(before));
  EXPECT_NEAR(known(after), known(before), 1e-9);
  EXPECT_LT(after.stats().entropy_bits, before.stats().entropy_bits)
      << "a binary OctoMap keeps voxels at their clamping bounds: more certain than one scan";

  // This run's keyframes go on top; moving them recomputes the map where they were and are,
  // the saved map included.
  after.addOwn(2, scanFrom(at(0, 0)), at(30, 0));
  EXPECT_GT(occupiedCount(after), occupiedCount(before) + 100);
  after.setOptimizedPoses({{2, at(30, 2)}});
  EXPECT_EQ(after.followPoses(0.0), 1U);
  EXPECT_GT(occupiedCount(after), occupiedCount(before) + 100) << "the saved map survived";
  EXPECT_GE(known(after), known(before));
  EXPECT_THROW(after.resume(dir), std::logic_error) << "after scans were added";

  // A map of another resolution, or not a map at all, is refused by name.
  MapperParams coarse = params();
  coarse.resolution_m = 0.4;
  MapperStage other("robot_a", coarse);
  try {
    other.resume(dir);
    ADD_FAILURE() << "a 0.2 m map resumed at 0.4 m";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/map.bt"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/map.bt") << "# Octomap OcTree binary file\nnot really\n";
  EXPECT_THROW(MapperStage("robot_a", params()).resume(dir), std::runtime_error);
  std::filesystem::remove_all(::testing::TempDir() + "map_stage_resume");
}

}  // namespace
}  // namespace ccir_mapping::core::information
