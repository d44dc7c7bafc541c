// The occupancy map's information (algorithms.md section 5.4): CSQMI against brute-force
// enumeration, its bounds; map entropy and known volume; the realised entropy drop of a scan;
// mutual information of mapped and new places; lazy greedy ranking equals naive greedy.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>

#include <pcl/common/transforms.h>

#include "ccir_mapping/core/information/csqmi.h"
#include "ccir_mapping/core/information/keyframe_map.h"
#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/scan_ranker.h"

namespace ccir_mapping::core::information {
namespace {

double gaussian(double x, double variance) {
  return std::exp(-0.5 * x * x / variance) / std::sqrt(2.0 * M_PI * variance);
}

/// CSQMI by enumerating all 2^C maps: each map's reading is its first occupied cell (or the
/// maximum range), and the three integrals of the definition are Gaussian products in z.
double bruteForceCsqmi(const BeamCells& beam, double sigma) {
  const std::size_t cells = beam.occupancy.size();
  std::vector<double> p_map;
  std::vector<double> reading;
  for (unsigned m = 0; m < (1U << cells); ++m) {
    double p = 1.0;
    double r = beam.max_range_m;
    bool hit = false;
    for (std::size_t i = 0; i < cells; ++i) {
      const bool occupied = (m >> i) & 1U;
      p *= occupied ? beam.occupancy[i] : 1 - beam.occupancy[i];
      if (occupied && !hit) {
        r = beam.range_m[i];
        hit = true;
      }
    }
    p_map.push_back(p);
    reading.push_back(r);
  }
  const double v = 2 * sigma * sigma;
  double joint = 0;    // integral of p(m, z)^2
  double sum_p2 = 0;   // sum of p(m)^2
  double pz2 = 0;      // integral of p(z)^2
  double product = 0;  // integral of p(m) p(z) p(m, z)
  for (std::size_t a = 0; a < p_map.size(); ++a) {
    joint += p_map[a] * p_map[a] * gaussian(0, v);
    sum_p2 += p_map[a] * p_map[a];
    double mixture = 0;
    for (std::size_t b = 0; b < p_map.size(); ++b) {
      pz2 += p_map[a] * p_map[b] * gaussian(reading[a] - reading[b], v);
      mixture += p_map[b] * gaussian(reading[a] - reading[b], v);
    }
    product += p_map[a] * p_map[a] * mixture;
  }
  return std::log(joint * sum_p2 * pz2 / (product * product));
}

BeamCells randomBeam(std::mt19937& rng, std::size_t cells, double cell_m) {
  std::uniform_real_distribution<double> u(0.02, 0.98);
  BeamCells beam;
  for (std::size_t i = 0; i < cells; ++i) {
    beam.occupancy.push_back(u(rng));
    beam.range_m.push_back((i + 0.5) * cell_m);
  }
  beam.max_range_m = cells * cell_m + cell_m;
  return beam;
}

TEST(Csqmi, EqualsBruteForceEnumeration) {
  std::mt19937 rng(3);
  for (const double sigma : {0.03, 0.1, 0.2}) {
    for (std::size_t cells = 1; cells <= 9; ++cells) {
      const BeamCells beam = randomBeam(rng, cells, 0.1);
      const double expected = bruteForceCsqmi(beam, sigma);
      EXPECT_NEAR(beamCsqmi(beam, sigma), expected, 1e-6 * std::max(1.0, expected))
          << cells << " cells, sigma " << sigma;
    }
  }
}

TEST(Csqmi, NonNegativeZeroWhenKnownLargestWhenUnknown) {
  BeamCells known;
  BeamCells unknown;
  for (int i = 0; i < 20; ++i) {
    known.occupancy.push_back(i == 12 ? 1 - 1e-6 : 1e-6);
    unknown.occupancy.push_back(0.5);
    known.range_m.push_back(0.1 * i + 0.05);
  }
  unknown.range_m = known.range_m;
  known.max_range_m = unknown.max_range_m = 2.5;
  EXPECT_NEAR(beamCsqmi(known, 0.03), 0.0, 1e-4);
  EXPECT_GT(beamCsqmi(unknown, 0.03), 0.5);
  // A known wall first hides everything behind it.
  BeamCells walled = unknown;
  walled.occupancy[0] = 1 - 1e-6;
  EXPECT_NEAR(beamCsqmi(walled, 0.03), 0.0, 1e-4);
  // Unknown cells behind a known-free corridor add information.
  BeamCells corridor = unknown;
  for (int i = 0; i < 10; ++i) corridor.occupancy[i] = 1e-6;
  BeamCells shorter = corridor;
  shorter.occupancy.resize(15);
  shorter.range_m.resize(15);
  EXPECT_GT(beamCsqmi(corridor, 0.03), beamCsqmi(shorter, 0.03));
  EXPECT_GE(beamCsqmi(BeamCells{}, 0.03), 0.0);
}

/// Returns of a ring lidar at `origin` inside the box room [-5, 5] x [-4, 4] x [-1, 2] (its
/// walls, floor and ceiling), 16 rings, one beam per degree.
pcl::PointCloud<pcl::PointXYZ> roomScan(const Eigen::Vector3d& origin) {
  const Eigen::Vector3d lo(-5, -4, -1);
  const Eigen::Vector3d hi(5, 4, 2);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (int ring = 0; ring < 16; ++ring) {
    const double elevation = (-15.0 + 2.0 * ring) * M_PI / 180;
    for (int a = 0; a < 360; ++a) {
      const double azimuth = a * M_PI / 180;
      const Eigen::Vector3d d(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      double t = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (d[k] > 1e-9) t = std::min(t, (hi[k] - origin[k]) / d[k]);
        if (d[k] < -1e-9) t = std::min(t, (lo[k] - origin[k]) / d[k]);
      }
      const Eigen::Vector3d p = origin + t * d;
      cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  return cloud;
}

MapperParams params() {
  MapperParams p;
  p.resolution_m = 0.2;
  p.max_insert_range_m = 20.0;
  return p;
}

TEST(EntropyCache, EqualsTheEntropyOfTheProbabilityAlsoWhenSlotsCollide) {
  // More distinct values than slots, each asked twice in two orders: a stale slot would show.
  EntropyCache cache;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> log_odds(-8.0F, 8.0F);
  std::vector<float> values{0.0F, -2.0F, 3.5F, 0.85F, -0.4F};
  for (int i = 0; i < 5000; ++i) values.push_back(log_odds(rng));
  for (int pass = 0; pass < 2; ++pass) {
    for (const float l : values) {
      const double p = 1.0 - 1.0 / (1.0 + std::exp(static_cast<double>(l)));
      ASSERT_DOUBLE_EQ(cache(l), occupancyEntropyBits(p)) << l;
    }
    std::reverse(values.begin(), values.end());
  }
  EXPECT_DOUBLE_EQ(cache(0.0F), 1.0);
}

TEST(OccupancyMap, EmptyBoxHoldsOneBitPerVoxel) {
  const OccupancyMap map(params());
  const Box box{{-1.0, -1.0, -1.0}, {0.9, 0.9, 0.9}};  // 10 x 10 x 10 voxels of 0.2 m
  EXPECT_DOUBLE_EQ(map.entropyBits(box), 1000.0);
  EXPECT_DOUBLE_EQ(map.knownVolumeM3(box), 0.0);
}

TEST(OccupancyMap, InsertingAScanLowersEntropyByItsPerVoxelDrops) {
  OccupancyMap map(params());
  const Box box{{-6, -5, -2}, {6, 5, 3}};
  const double empty = map.entropyBits(box);
  const auto update = map.computeUpdate(roomScan({0, 0, 0}), {0, 0, 0});
  ASSERT_GT(update.occupied.size(), 100U);
  ASSERT_GT(update.free.size(), 1000U);
  {  // The same voxels as OctoMap's own computeUpdate.
    octomap::Pointcloud cloud;
    for (const auto& p : roomScan({0, 0, 0})) cloud.push_back(p.x, p.y, p.z);
    octomap::KeySet free_cells;
    octomap::KeySet occupied_cells;
    octomap::OcTree tree(map.tree().getResolution());
    tree.computeUpdate(cloud, {0, 0, 0}, free_cells, occupied_cells,
                       map.params().max_insert_range_m);
    EXPECT_EQ(update.free.size(), free_cells.size());
    EXPECT_EQ(update.occupied.size(), occupied_cells.size());
    for (const auto& key : update.free) ASSERT_TRUE(free_cells.count(key));
    for (const auto& key : update.occupied) ASSERT_TRUE(occupied_cells.count(key));
  }
  const double predicted = map.entropyReduction(update);
  double gains = 0;
  for (const auto& [key, gain] : map.voxelGains(update)) gains += gain;
  EXPECT_NEAR(gains, predicted, 1e-6 * predicted) << "no voxel of an empty map gains entropy";
  // A scan given in its sensor frame with the sensor's pose: the rays start at the sensor.
  Pose3 sensor(Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()));
  sensor.translation() << 1.0, -0.5, 0.3;
  pcl::PointCloud<pcl::PointXYZ> in_sensor;
  pcl::transformPointCloud(roomScan(sensor.translation()), in_sensor,
                           sensor.inverse().matrix().cast<float>());
  pcl::PointCloud<pcl::PointXYZ> back;
  pcl::transformPointCloud(in_sensor, back, sensor.matrix().cast<float>());
  const auto posed = map.computeUpdate(in_sensor, sensor);
  const auto expected = map.computeUpdate(back, sensor.translation());
  EXPECT_EQ(posed.occupied, expected.occupied);
  EXPECT_EQ(posed.free, expected.free);
  EXPECT_NE(posed.free, map.computeUpdate(back, Eigen::Vector3d::Zero()).free);
  Pose3 nan_sensor = sensor;
  nan_sensor(0, 0) = std::nan("");
  EXPECT_THROW(map.computeUpdate(in_sensor, nan_sensor), std::invalid_argument);
  map.insert(update);
  EXPECT_NEAR(empty - map.entropyBits(box), predicted, 1e-6 * predicted);
  // Its occupied voxels lie on the room's walls, floor and ceiling.
  const auto occupied = map.occupiedCentres();
  ASSERT_EQ(occupied.size(), update.occupied.size());
  for (const auto& p : occupied) {
    const double to_wall = std::min({5 - std::abs(p.x), 4 - std::abs(p.y), p.z + 1, 2 - p.z});
    ASSERT_LT(std::abs(to_wall), 0.2) << p.x << " " << p.y << " " << p.z;
  }
  const double voxel_m3 = std::pow(0.2, 3);
  EXPECT_NEAR(map.knownVolumeM3(box), (update.free.size() + update.occupied.size()) * voxel_m3,
              1e-9);

  // A second scan from elsewhere in the room: the prediction still equals the change.
  const auto second = map.computeUpdate(roomScan({2, 1, 0.5}), {2, 1, 0.5});
  const double before = map.entropyBits(box);
  const double second_predicted = map.entropyReduction(second);
  map.insert(second);
  EXPECT_NEAR(before - map.entropyBits(box), second_predicted,
              1e-6 * std::abs(second_predicted) + 1e-6);
  // The entropy box's statistics follow every insertion (the default box holds the room).
  const Box params_box{map.params().entropyBoxMin(), map.params().entropyBoxMax()};
  EXPECT_NEAR(map.boxEntropyBits(), map.entropyBits(params_box), 1e-9 * map.boxEntropyBits());
  EXPECT_NEAR(map.boxKnownVolumeM3(), map.knownVolumeM3(params_box), 1e-9);
  EXPECT_GT(map.boxKnownVolumeM3(), 0.0);
  // A scan inserted from its sensor frame changes the same voxels as its computed update.
  OccupancyMap direct(params());
  OccupancyMap via_update(params());
  direct.insert(in_sensor, sensor);
  via_update.insert(via_update.computeUpdate(in_sensor, sensor));
  EXPECT_EQ(direct.occupiedCentres().size(), via_update.occupiedCentres().size());
  EXPECT_DOUBLE_EQ(direct.boxEntropyBits(), via_update.boxEntropyBits());
  EXPECT_DOUBLE_EQ(direct.boxKnownVolumeM3(), via_update.boxKnownVolumeM3());
  EXPECT_NEAR(direct.entropyBits(params_box), via_update.entropyBits(params_box), 1e-6);
  // Pruning merges equal voxels, it does not change the entropy.
  const double unpruned = map.entropyBits(box);
  const_cast<octomap::OcTree&>(map.tree()).prune();
  EXPECT_NEAR(map.entropyBits(box), unpruned, 1e-6 * unpruned);
}

TEST(OccupancyMap, UpdatesEachVoxelAsOctomapsUpdateNodeEvenInsidePrunedLeaves) {
  OccupancyMap map(params());
  octomap::OcTree reference(map.tree().getResolution());
  reference.setClampingThresMin(map.params().occupancy_clamp_min);
  reference.setClampingThresMax(map.params().occupancy_clamp_max);
  const auto apply = [&](const ScanUpdate& update) {
    map.insert(update);
    for (const auto& key : update.free) reference.updateNode(key, false, /*lazy_eval=*/true);
    for (const auto& key : update.occupied) reference.updateNode(key, true, /*lazy_eval=*/true);
  };
  const auto first = map.computeUpdate(roomScan({0, 0, 0}), {0, 0, 0});
  apply(first);
  // Equal free voxels merge into coarser leaves, which the next scan must split again.
  const_cast<octomap::OcTree&>(map.tree()).prune();
  reference.prune();
  ASSERT_LT(map.tree().getNumLeafNodes(), first.free.size() + first.occupied.size());
  const auto second = map.computeUpdate(roomScan({2, 1, 0.5}), {2, 1, 0.5});
  apply(second);
  for (const ScanUpdate* update : {&first, &second}) {
    for (const auto* keys : {&update->free, &update->occupied}) {
      for (const auto& key : *keys) {
        ASSERT_FLOAT_EQ(map.occupancy(key), reference.search(key)->getOccupancy());
      }
    }
  }
  const Box params_box{map.params().entropyBoxMin(), map.params().entropyBoxMax()};
  EXPECT_NEAR(map.boxEntropyBits(), map.entropyBits(params_box), 1e-9 * map.boxEntropyBits());
  EXPECT_NEAR(map.boxKnownVolumeM3(), map.knownVolumeM3(params_box), 1e-9);
}

TEST(OccupancyMap, MutualInformationIsAboutZeroWhereMappedAndLargeWhereNew) {
  OccupancyMap map(params());
  const auto scan = roomScan({0, 0, 0});
  const OccupancyMap empty(params());
  const double fresh = map.scanCsqmi(scan, {0, 0, 0});
  for (int i = 0; i < 12; ++i) map.insert(map.computeUpdate(scan, {0, 0, 0}));  // clamped
  const double mapped = map.scanCsqmi(scan, {0, 0, 0});
  EXPECT_GT(fresh, 10.0);
  EXPECT_LT(mapped, 0.05 * fresh) << "fresh " << fresh;
  // The same for a simulated sensor: at the mapped pose, and far from anything mapped.
  Pose3 there = Pose3::Identity();
  Pose3 elsewhere = Pose3::Identity();
  elsewhere.translation() << 60, 0, 0;
  EXPECT_LT(map.simulatedCsqmi(there), 0.05 * map.simulatedCsqmi(elsewhere));
  EXPECT_GT(map.simulatedCsqmi(elsewhere), 0.0);
  // And realised: re-inserting what the map holds removes (almost) nothing.
  EXPECT_LT(map.entropyReduction(map.computeUpdate(scan, {0, 0, 0})),
            0.01 * empty.entropyReduction(empty.computeUpdate(scan, {0, 0, 0})));
}

TEST(OccupancyMap, ABeamThroughFreeSpaceVisitsTheWholeRaysCells) {
  // A beam that never meets an obstacle runs to the insertion range; traced in segments, its
  // cells must be those of the whole ray in one go, once each and in order.
  OccupancyMap map(params());
  const Eigen::Vector3d origin(0.05, 0.03, 0.4);
  const Eigen::Vector3d direction(1.0, 0.37, -0.05);
  const Eigen::Vector3d end = origin + direction.normalized() * map.params().max_insert_range_m;
  octomap::KeyRay ray;
  ASSERT_TRUE(map.tree().computeRayKeys(octomap::point3d(origin.x(), origin.y(), origin.z()),
                                        octomap::point3d(end.x(), end.y(), end.z()), ray));
  ScanUpdate free_ray;
  for (const auto& key : ray) free_ray.free.push_back(key);
  for (int i = 0; i < 12; ++i) map.insert(free_ray);  // clamped free
  const BeamCells beam = map.beamCells(origin, direction);
  ASSERT_EQ(beam.occupancy.size(), ray.size());
  std::size_t i = 0;
  for (const auto& key : ray) {
    const octomap::point3d c = map.tree().keyToCoord(key);
    EXPECT_NEAR(beam.range_m[i], (Eigen::Vector3d(c.x(), c.y(), c.z()) - origin).norm(), 1e-5);
    EXPECT_LT(beam.occupancy[i], 0.05);
    ++i;
  }
}

TEST(OccupancyMap, BadInputIsDroppedAndCounted) {
  OccupancyMap map(params());
  auto scan = roomScan({0, 0, 0});
  scan.push_back(pcl::PointXYZ(std::nanf(""), 0, 0));
  scan.push_back(pcl::PointXYZ(0, std::numeric_limits<float>::infinity(), 0));
  const auto update = map.computeUpdate(scan, {0, 0, 0});
  EXPECT_EQ(update.dropped_points, 2);
  EXPECT_FALSE(update.occupied.empty());
  const auto none = map.computeUpdate(pcl::PointCloud<pcl::PointXYZ>{}, {0, 0, 0});
  EXPECT_TRUE(none.free.empty() && none.occupied.empty());
  EXPECT_EQ(map.entropyReduction(none), 0.0);
  EXPECT_THROW(map.computeUpdate(scan, {std::nan(""), 0, 0}), std::invalid_argument);
  Pose3 nan_pose = Pose3::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW(map.simulatedCsqmi(nan_pose), std::invalid_argument);
  // A box OctoMap cannot address would be measured as empty: refused, naming the parameter.
  MapperParams far = params();
  far.entropy_box_half_width_m = 7000.0;  // beyond 32767 x 0.2 m
  ASSERT_FALSE(far.validate().empty());
  EXPECT_NE(far.validate().front().find("entropy_box_half_width_m"), std::string::npos);
  MapperParams bad = params();
  bad.resolution_m = 0;
  try {
    OccupancyMap invalid(bad);
    FAIL() << "accepted resolution_m = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("resolution_m"), std::string::npos);
  }
}

TEST(ScanRanker, LazyGreedyEqualsNaiveGreedyWithFarFewerEvaluations) {
  // Scans along a corridor of voxels: neighbours overlap, so ranking must look at what the
  // chosen ones already cover.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> gain(0.01F, 1.0F);
  std::uniform_int_distribution<int> start(0, 2000);
  std::vector<std::vector<VoxelGain>> scans(200);
  std::vector<double> bonus;
  for (auto& scan : scans) {
    const int first = start(rng);
    for (int v = first; v < first + 300; ++v) {
      scan.emplace_back(octomap::OcTreeKey(static_cast<octomap::key_type>(v), 7, 7), gain(rng));
    }
    bonus.push_back(gain(rng) * 5);
  }
  const ScanRanker ranker(scans, bonus);
  const auto naive = ranker.rankNaive(15);
  const std::size_t naive_evaluations = ranker.evaluations();
  const auto lazy = ranker.rankLazy(15);
  ASSERT_EQ(naive.size(), 15U);
  ASSERT_EQ(lazy.size(), naive.size());
  for (std::size_t i = 0; i < naive.size(); ++i) {
    EXPECT_EQ(lazy[i].index, naive[i].index) << "rank " << i;
    EXPECT_DOUBLE_EQ(lazy[i].gain, naive[i].gain);
    if (i > 0) EXPECT_LE(naive[i].gain, naive[i - 1].gain) << "gains diminish";
  }
  EXPECT_LT(ranker.evaluations() * 4, naive_evaluations);
  // The first choice is the scan worth most alone.
  double best = 0;
  for (std::size_t s = 0; s < scans.size(); ++s) {
    double alone = bonus[s];
    for (const auto& [key, g] : scans[s]) alone += g;
    best = std::max(best, alone);
  }
  EXPECT_DOUBLE_EQ(naive.front().gain, best);
  // Asking for more than there are returns them all; a bonus per scan or none.
  EXPECT_EQ(ScanRanker(scans).rankLazy(500).size(), scans.size());
  EXPECT_THROW(ScanRanker(scans, {1.0}), std::invalid_argument);
}

Pose3 at(double x, double y, double yaw_deg = 0) {
  return Eigen::Translation3d(x, y, 0) *
         Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ());
}

TEST(OccupancyMap, ASnapshotRestoresTheMapInAFractionOfItsMemory) {
  OccupancyMap map(params());
  map.insert(roomScan({0, 0, 0}), at(0, 0));
  map.insert(roomScan({0, 0, 0}), at(2, 1, 30));
  const auto snapshot = map.snapshot();
  EXPECT_LT(snapshot.tree.size() * 4, map.tree().memoryUsage()) << "compact";
  OccupancyMap restored(params(), snapshot);
  EXPECT_EQ(restored.tree().size(), map.tree().size());
  for (auto it = map.tree().begin_leafs(); it != map.tree().end_leafs(); ++it) {
    ASSERT_FLOAT_EQ(restored.occupancy(it.getKey()), it->getOccupancy());
  }
  // It goes on as the original would, entropy box included.
  for (OccupancyMap* m : {&map, &restored}) m->insert(roomScan({0, 0, 0}), at(4, 0, 60));
  EXPECT_DOUBLE_EQ(restored.boxEntropyBits(), map.boxEntropyBits());
  EXPECT_DOUBLE_EQ(restored.boxKnownVolumeM3(), map.boxKnownVolumeM3());
  const Box box{params().entropyBoxMin(), params().entropyBoxMax()};
  EXPECT_NEAR(restored.boxEntropyBits(), restored.entropyBits(box), 1e-9 * map.boxEntropyBits());
}

TEST(KeyframeMap, FollowsOptimizedPosesAndPlacesTeammatesOnceTheirFrameIsKnown) {
  KeyframeMap map(params());
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  EXPECT_TRUE(map.addOwn(1, cloud, at(0, 0)).map_from_sensor.isApprox(at(0, 0)));
  map.addOwn(2, cloud, at(2, 0));
  // The Backend moves keyframe 2 by 0.1 m: under the rebuild threshold (0.2 m).
  map.setOptimizedPoses({{1, at(0, 0)}, {2, at(2, 0.1)}});
  EXPECT_FALSE(map.rebuildDue());
  // A new keyframe is placed with the latest correction.
  EXPECT_TRUE(map.addOwn(3, cloud, at(4, 0)).map_from_sensor.isApprox(at(4, 0.1)));
  // A loop closure moves keyframe 2 by 0.5 m and 2 degrees: rebuild, at the optimised poses.
  map.setOptimizedPoses({{2, at(2, 0.5, 2)}, {99, at(9, 9)}});
  EXPECT_TRUE(map.rebuildDue());
  auto all = map.placeAll();
  EXPECT_FALSE(map.rebuildDue());
  ASSERT_EQ(all.size(), 3U);
  EXPECT_TRUE(all[1].map_from_sensor.isApprox(at(2, 0.5, 2)));

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
  // The same estimate again changes nothing; a better one 1 m away makes a rebuild due.
  map.setTeamTransform("robot_b", at(10, 0, 90));
  EXPECT_FALSE(map.rebuildDue());
  map.setTeamTransform("robot_b", at(11, 0, 90));
  EXPECT_TRUE(map.rebuildDue());
  EXPECT_EQ(map.placeAll().size(), 5U);
}

TEST(KeyframeMap, PlacesTeammatesScansWhereTheTeamGraphPutsThemAndRebuildsWhenTheyMove) {
  KeyframeMap map(params());
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
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
  EXPECT_FALSE(map.rebuildDue()) << "7 did not move";
  // The graph moves 8 by 0.1 m (below the 0.2 m threshold), then 7 by 0.5 m.
  EXPECT_TRUE(map.setPeerPoses("robot_b", {{8, at(12, 1.1)}}).empty());
  EXPECT_FALSE(map.rebuildDue());
  map.setPeerPoses("robot_b", {{7, at(5, 5.5, 30)}});
  EXPECT_TRUE(map.rebuildDue());
  const auto all = map.placeAll();
  ASSERT_EQ(all.size(), 2U);
  EXPECT_TRUE(all[0].map_from_sensor.isApprox(at(5, 5.5, 30)));
  EXPECT_TRUE(all[1].map_from_sensor.isApprox(at(12, 1.1)));
  EXPECT_EQ(map.peerScans(), 2U);
}

TEST(KeyframeMap, SettlesTheOldestPlacedScansBeyondTheRebuildWindow) {
  MapperParams p = params();
  p.rebuild_window_scans = 2;
  KeyframeMap map(p);
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  map.addOwn(1, cloud, at(0, 0));
  map.addOwn(2, cloud, at(2, 0));
  map.addPeer("robot_b", 7, cloud, at(1, 1));  // waits for robot_b's frame: not placed
  EXPECT_FALSE(map.settleDue()) << "two placed scans fit the window";
  map.addOwn(3, cloud, at(4, 0));
  map.setTeamTransform("robot_b", at(10, 0));  // places 7 after 3
  map.setOptimizedPoses({{2, at(2, 0.5)}});
  ASSERT_TRUE(map.settleDue());
  const auto settled = map.settle();
  ASSERT_EQ(settled.size(), 2U) << "the oldest placed: keyframes 1 and 2";
  EXPECT_TRUE(settled[0].map_from_sensor.isApprox(at(0, 0)));
  EXPECT_TRUE(settled[1].map_from_sensor.isApprox(at(2, 0.5))) << "at its pose of the moment";
  EXPECT_FALSE(map.settleDue());
  EXPECT_EQ(map.settledScans(), 2U);
  EXPECT_EQ(map.ownKeyframes(), 3U);
  EXPECT_EQ(map.peerScans(), 1U);
  // A settled scan is never placed again, however far it moves.
  EXPECT_EQ(map.placeAll().size(), 2U);
  map.setOptimizedPoses({{1, at(0, 5)}});
  EXPECT_FALSE(map.rebuildDue());
  map.addOwn(4, cloud, at(6, 0));
  map.addOwn(5, cloud, at(8, 0));
  const auto next = map.settle();
  ASSERT_EQ(next.size(), 2U) << "keyframe 3, then robot_b's 7";
  EXPECT_TRUE(next[1].map_from_sensor.isApprox(at(10, 0) * at(1, 1)));
  EXPECT_TRUE(map.holdsPeer("robot_b", 7)) << "settled, still held";
  EXPECT_TRUE(map.addPeer("robot_b", 7, cloud, at(1, 1)).empty()) << "not placed twice";
  EXPECT_EQ(map.peerScans(), 1U);
  EXPECT_EQ(map.pendingPeerScans(), 0U);
}

TEST(MapperStage, RebuildsAtTheOptimisedPosesWithoutLosingScansPlacedMeanwhile) {
  std::mutex mutex;
  std::condition_variable changed;
  bool rebuilding = false, go_on = false;
  std::vector<std::size_t> rebuilt;
  MapperStage::Hooks hooks;
  hooks.run = [&](const char* stage, const std::function<void()>& work) {
    if (std::string(stage) == "rebuild") {  // holds the rebuild until the test lets it go
      std::unique_lock<std::mutex> lock(mutex);
      rebuilding = true;
      changed.notify_all();
      changed.wait(lock, [&] { return go_on; });
    }
    work();
  };
  hooks.rebuilt = [&](std::size_t scans, double) {
    std::lock_guard<std::mutex> lock(mutex);
    rebuilt.push_back(scans);
    changed.notify_all();
  };
  MapperStage stage("robot_a", params(), hooks);
  KeyframeMap expected(params());  // the same inputs, placed without a stage
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  for (Stamp stamp : {1, 2}) {
    stage.addOwn(stamp, cloud, at(2.0 * double(stamp), 0));
    expected.addOwn(stamp, cloud, at(2.0 * double(stamp), 0));
  }
  EXPECT_FALSE(stage.rebuildIfDue(0.0)) << "nothing moved";
  stage.setOptimizedPoses({{2, at(4, 0.5, 2)}});
  expected.setOptimizedPoses({{2, at(4, 0.5, 2)}});
  ASSERT_TRUE(stage.rebuildIfDue(0.0));
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(60), [&] { return rebuilding; }));
  }
  EXPECT_FALSE(stage.rebuildIfDue(100.0)) << "one rebuild at a time";
  stage.addOwn(3, cloud, at(6, 0));  // placed while the rebuild runs
  expected.addOwn(3, cloud, at(6, 0));
  EXPECT_FALSE(stage.addPeer("robot_b", 7, cloud, at(1, 1)));
  EXPECT_EQ(stage.addPeer("robot_b", 7, cloud, at(1, 1)), "it is in the map already");
  EXPECT_EQ(stage.addPeer("robot_a", 8, cloud, at(1, 1)), "it is this robot's own");
  stage.setTeamTransform("robot_a", at(50, 50));  // ignored: it would place nothing anyway
  {
    std::lock_guard<std::mutex> lock(mutex);
    go_on = true;
    changed.notify_all();
  }
  stage.waitForRebuild();
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(60), [&] { return !rebuilt.empty(); }));
    EXPECT_EQ(rebuilt, (std::vector<std::size_t>{2}));
  }
  const auto stats = stage.stats();
  EXPECT_EQ(stats.rebuilds, 1U);
  EXPECT_EQ(stats.keyframes, 3U);
  EXPECT_EQ(stats.pending_peer_scans, 1U);
  OccupancyMap direct(params());
  for (const auto& scan : expected.placeAll()) direct.insert(*scan.cloud, scan.map_from_sensor);
  EXPECT_NEAR(stats.entropy_bits, direct.boxEntropyBits(), 1e-6)
      << "the rebuilt map holds all three keyframes at their current poses";
  EXPECT_NEAR(stats.known_volume_m3, direct.boxKnownVolumeM3(), 1e-9);
}

TEST(MapperStage, ARebuildWaitsInProportionToTheScansTheLastOnePlaced) {
  MapperParams p = params();
  p.rebuild_wait_s_per_scan = 10.0;
  MapperStage stage("robot_a", p);
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  for (Stamp stamp : {1, 2, 3}) stage.addOwn(stamp, cloud, at(2.0 * double(stamp), 0));
  stage.setOptimizedPoses({{3, at(6, 0.5, 3)}});
  ASSERT_TRUE(stage.rebuildIfDue(100.0)) << "the first rebuild waits for nothing";
  stage.waitForRebuild();
  stage.setOptimizedPoses({{3, at(6, 1.0, 3)}});
  EXPECT_FALSE(stage.rebuildIfDue(129.0)) << "3 scans x 10 s: not before 130 s";
  EXPECT_TRUE(stage.rebuildIfDue(130.0));
  stage.waitForRebuild();
  EXPECT_EQ(stage.stats().rebuilds, 2U);
}

TEST(MapperStage, SaveWritesTheMapIntoAFolderItCreatesAndOctoMapReadsItBack) {
  MapperStage stage("robot_a", params());
  stage.addOwn(1, std::make_shared<const Cloud>(roomScan({0, 0, 0})), at(0, 0));
  const std::string dir = ::testing::TempDir() + "map_stage_save/robot_a";
  std::filesystem::remove_all(dir);
  const std::string path = stage.save(dir);
  EXPECT_EQ(path, dir + "/map.bt");
  octomap::OcTree read(0.1);
  ASSERT_TRUE(read.readBinary(path));
  const std::size_t occupied =
      stage.map()->read([](const auto& map) { return map.occupiedCentres().size(); });
  std::size_t read_occupied = 0;
  for (auto it = read.begin_leafs(); it != read.end_leafs(); ++it) {
    read_occupied += read.isNodeOccupied(*it);
  }
  EXPECT_GT(occupied, 100U);
  EXPECT_EQ(read_occupied, occupied);

  const std::string blocked = ::testing::TempDir() + "map_stage_save/a_file";
  std::ofstream(blocked) << "not a folder";
  EXPECT_THROW(stage.save(blocked + "/robot_a"), std::runtime_error);
  std::filesystem::remove_all(::testing::TempDir() + "map_stage_save");
}

TEST(MapperStage, AResumedStageContinuesTheSavedMapAndKeepsItThroughRebuilds) {
  const std::string dir = ::testing::TempDir() + "map_stage_resume/robot_a";
  std::filesystem::remove_all(dir);
  auto occupied = [](const MapperStage& stage) {
    return stage.map()->read([](const auto& map) { return map.occupiedCentres().size(); });
  };
  auto known = [](const MapperStage& stage) { return stage.stats().known_volume_m3; };
  MapperStage before("robot_a", params());
  before.addOwn(1, std::make_shared<const Cloud>(roomScan({0, 0, 0})), at(0, 0));
  before.save(dir);

  MapperStage after("robot_a", params());
  EXPECT_FALSE(after.resume(dir + "/nothing_here")) << "no saved map: nothing to resume";
  ASSERT_TRUE(after.resume(dir));
  EXPECT_EQ(occupied(after), occupied(before));
  EXPECT_NEAR(known(after), known(before), 1e-9);
  EXPECT_LT(after.stats().entropy_bits, before.stats().entropy_bits)
      << "a binary OctoMap keeps voxels at their clamping bounds: more certain than one scan";

  // This run's keyframes go on top; a rebuild at moved poses starts from the saved map.
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  after.addOwn(2, cloud, at(30, 0));
  const std::size_t with_new = occupied(after);
  EXPECT_GT(with_new, occupied(before) + 100);
  after.setOptimizedPoses({{2, at(30, 2)}});
  ASSERT_TRUE(after.rebuildIfDue(0.0));
  after.waitForRebuild();
  EXPECT_EQ(after.stats().rebuilds, 1U);
  EXPECT_GT(occupied(after), occupied(before) + 100) << "the saved map survived the rebuild";
  EXPECT_GE(known(after), known(before));

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

TEST(MapperStage, ARebuildStartsFromTheSettledScansAndReplacesOnlyTheWindow) {
  MapperParams p = params();
  p.rebuild_window_scans = 2;
  MapperStage stage("robot_a", p);
  auto cloud = std::make_shared<const Cloud>(roomScan({0, 0, 0}));
  for (Stamp stamp : {1, 2, 3}) stage.addOwn(stamp, cloud, at(2.0 * double(stamp), 0));
  EXPECT_FALSE(stage.rebuildIfDue(0.0)) << "nothing moved: keyframe 1 is only settled";
  stage.waitForRebuild();
  EXPECT_EQ(stage.stats().settled_scans, 1U);
  EXPECT_EQ(stage.stats().rebuilds, 0U);
  stage.setOptimizedPoses({{1, at(2, 1)}, {2, at(4, 1)}, {3, at(6, 1)}});
  ASSERT_TRUE(stage.rebuildIfDue(0.0));
  stage.waitForRebuild();
  const auto stats = stage.stats();
  EXPECT_EQ(stats.rebuilds, 1U);
  EXPECT_EQ(stats.keyframes, 3U);
  OccupancyMap windowed(p), unbounded(p);
  windowed.insert(*cloud, at(2, 0));
  unbounded.insert(*cloud, at(2, 1));
  for (OccupancyMap* m : {&windowed, &unbounded}) {
    m->insert(*cloud, at(4, 1));
    m->insert(*cloud, at(6, 1));
  }
  EXPECT_NEAR(stats.entropy_bits, windowed.boxEntropyBits(), 1e-6)
      << "keyframe 1 where it was settled, 2 and 3 at their optimised poses";
  EXPECT_GT(std::abs(stats.entropy_bits - unbounded.boxEntropyBits()), 1.0);
}

TEST(ScanRanker, CoarsenedGainsSumPerBlock) {
  const std::vector<VoxelGain> gains = {{octomap::OcTreeKey(8, 8, 8), 0.5F},
                                        {octomap::OcTreeKey(15, 9, 8), 0.25F},
                                        {octomap::OcTreeKey(16, 8, 8), 1.0F}};
  const auto blocks = coarsened(gains, 3);
  ASSERT_EQ(blocks.size(), 2U);
  EXPECT_EQ(blocks[0].first, octomap::OcTreeKey(1, 1, 1));
  EXPECT_FLOAT_EQ(blocks[0].second, 0.75F);
  EXPECT_EQ(blocks[1].first, octomap::OcTreeKey(2, 1, 1));
  EXPECT_FLOAT_EQ(blocks[1].second, 1.0F);
  EXPECT_EQ(coarsened(gains, 0).size(), 3U);
}

}  // namespace
}  // namespace ccir_mapping::core::information
