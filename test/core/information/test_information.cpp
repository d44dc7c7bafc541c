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
#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/scan_ranker.h"
#include "room_scan.h"

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
    octomap::OcTree tree(map.grid().getResolution());
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
}

TEST(OccupancyMap, UpdatesEachVoxelAsOctomapsUpdateNode) {
  OccupancyMap map(params());
  octomap::OcTree reference(map.grid().getResolution());
  reference.setClampingThresMin(map.params().occupancy_clamp_min);
  reference.setClampingThresMax(map.params().occupancy_clamp_max);
  const auto apply = [&](const ScanUpdate& update) {
    map.insert(update);
    for (const auto& key : update.free) reference.updateNode(key, false, /*lazy_eval=*/true);
    for (const auto& key : update.occupied) reference.updateNode(key, true, /*lazy_eval=*/true);
  };
  const auto first = map.computeUpdate(roomScan({0, 0, 0}), {0, 0, 0});
  apply(first);
  // The reference's equal free voxels merge into coarser leaves, which the next scan splits.
  reference.prune();
  ASSERT_LT(reference.getNumLeafNodes(), first.free.size() + first.occupied.size());
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
  ASSERT_TRUE(map.grid().computeRayKeys(octomap::point3d(origin.x(), origin.y(), origin.z()),
                                        octomap::point3d(end.x(), end.y(), end.z()), ray));
  ScanUpdate free_ray;
  for (const auto& key : ray) free_ray.free.push_back(key);
  for (int i = 0; i < 12; ++i) map.insert(free_ray);  // clamped free
  const BeamCells beam = map.beamCells(origin, direction);
  ASSERT_EQ(beam.occupancy.size(), ray.size());
  std::size_t i = 0;
  for (const auto& key : ray) {
    const octomap::point3d c = map.grid().keyToCoord(key);
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
    if (i > 0) {
      EXPECT_LE(naive[i].gain, naive[i - 1].gain) << "gains diminish";
    }
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

  // Over a held map, with each scan's marginal over it given (as the Broker keeps them): the
  // same ranking as when the ranker computes them.
  Coverage held;
  for (std::size_t s = 0; s < scans.size(); s += 7) held.add(scans[s]);
  std::vector<const std::vector<VoxelGain>*> kept;
  std::vector<double> marginals;
  for (const auto& scan : scans) {
    kept.push_back(&scan);
    marginals.push_back(held.marginal(scan));
  }
  const auto computed = ScanRanker(kept, bonus, &held).rankLazy(15);
  const auto given = ScanRanker(kept, bonus, &held, marginals).rankLazy(15);
  ASSERT_EQ(given.size(), computed.size());
  for (std::size_t i = 0; i < given.size(); ++i) {
    EXPECT_EQ(given[i].index, computed[i].index) << "rank " << i;
    EXPECT_DOUBLE_EQ(given[i].gain, computed[i].gain);
  }
  EXPECT_NE(computed.front().index, lazy.front().index) << "the held map changes the ranking";
  EXPECT_THROW(ScanRanker(kept, bonus, &held, {1.0}), std::invalid_argument);
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
