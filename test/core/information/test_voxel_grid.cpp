#include <gtest/gtest.h>

#include <map>
#include <random>
#include <tuple>

#include "ccir_mapping/core/information/voxel_grid.h"

namespace ccir_mapping::core::information {
namespace {

using Reference = std::map<std::tuple<int, int, int>, float>;

std::tuple<int, int, int> tupleOf(const octomap::OcTreeKey& key) {
  return {key[0], key[1], key[2]};
}

void expectHolds(const VoxelGrid<float>& grid, const Reference& reference) {
  ASSERT_EQ(grid.voxels(), reference.size());
  for (const auto& [at, log_odds] : reference) {
    const float* found =
        grid.find(octomap::OcTreeKey(std::get<0>(at), std::get<1>(at), std::get<2>(at)));
    ASSERT_NE(found, nullptr);
    ASSERT_EQ(*found, log_odds);
  }
  std::size_t listed = 0;
  std::uint64_t previous = 0;
  grid.forEach([&](const octomap::OcTreeKey& key, float log_odds) {
    const std::uint64_t code = KeyBricks::morton(key);
    if (listed++ > 0) {
      ASSERT_LT(previous, code) << "the octree's depth-first order";
    }
    previous = code;
    const auto it = reference.find(tupleOf(key));
    ASSERT_NE(it, reference.end());
    ASSERT_EQ(it->second, log_odds);
  });
  EXPECT_EQ(listed, reference.size());
}

TEST(VoxelGrid, HoldsWhatWasSetAndForgetsWhatWasErasedInWhateverOrder) {
  VoxelGrid<float> grid;
  Reference reference;
  const std::size_t empty_bytes = grid.bytes();
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> near(32740, 32800);  // dense: many voxels a brick
  std::uniform_int_distribution<int> anywhere(0, 65535);  // sparse: a voxel a brick
  std::uniform_real_distribution<float> value(-2.0F, 3.5F);
  for (int i = 0; i < 60000; ++i) {
    auto& d = i % 4 ? near : anywhere;
    const octomap::OcTreeKey key(d(rng), d(rng), d(rng));
    if (i % 3 == 0) {
      grid.erase(key);
      reference.erase(tupleOf(key));
      continue;
    }
    bool created = false;
    float& v = grid.at(key, created);
    EXPECT_EQ(created, reference.count(tupleOf(key)) == 0);
    if (created) {
      EXPECT_EQ(v, 0.0F) << "a new voxel starts at an even chance";
    }
    v = value(rng);
    reference[tupleOf(key)] = v;
  }
  expectHolds(grid, reference);
  EXPECT_EQ(grid.find(octomap::OcTreeKey(1, 1, 1)) != nullptr, reference.count({1, 1, 1}) > 0);

  // A box: exactly the known voxels inside it, whole bricks and cut ones.
  const octomap::OcTreeKey min(32750, 32745, 32760);
  const octomap::OcTreeKey max(32790, 32771, 32777);
  std::size_t inside = 0;
  for (const auto& [at, v] : reference) {
    const auto& [x, y, z] = at;
    inside +=
        x >= min[0] && x <= max[0] && y >= min[1] && y <= max[1] && z >= min[2] && z <= max[2];
  }
  std::size_t listed = 0;
  grid.forEachIn(min, max, [&](const octomap::OcTreeKey& key, float log_odds) {
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(key[a] >= min[a] && key[a] <= max[a]);
    ASSERT_EQ(reference.at(tupleOf(key)), log_odds);
    ++listed;
  });
  EXPECT_GT(inside, 1000U);
  EXPECT_EQ(listed, inside);

  // Erasing everything releases every brick: memory follows the known voxels.
  const std::size_t full_bytes = grid.bytes();
  EXPECT_GT(full_bytes, reference.size() * 4);
  for (const auto& [at, v] : reference) {
    grid.erase(octomap::OcTreeKey(std::get<0>(at), std::get<1>(at), std::get<2>(at)));
  }
  expectHolds(grid, {});
  EXPECT_LT(grid.bytes(), full_bytes / 10);
  // Released bricks are reused.
  bool created = false;
  grid.at(octomap::OcTreeKey(5, 6, 7), created) = 1.5F;
  EXPECT_TRUE(created);
  expectHolds(grid, {{{5, 6, 7}, 1.5F}});
  grid.clear();
  EXPECT_EQ(grid.voxels(), 0U);
  EXPECT_EQ(grid.bytes(), empty_bytes);
}

TEST(VoxelGrid, IntegersKnowEveryValueButTheLowest) {
  VoxelGrid<std::int16_t> grid;
  bool created = false;
  grid.at(octomap::OcTreeKey(9, 9, 9), created) = -4600;
  EXPECT_TRUE(created);
  EXPECT_EQ(grid.at(octomap::OcTreeKey(9, 9, 10), created), 0) << "new: 0";
  EXPECT_TRUE(created);
  ASSERT_NE(grid.find(octomap::OcTreeKey(9, 9, 10)), nullptr) << "0 is a value";
  EXPECT_EQ(*grid.find(octomap::OcTreeKey(9, 9, 9)), -4600);
  EXPECT_EQ(grid.find(octomap::OcTreeKey(9, 10, 9)), nullptr);
  EXPECT_EQ(grid.voxels(), 2U);
  grid.at(octomap::OcTreeKey(9, 9, 9), created) += 100;
  EXPECT_FALSE(created);
  EXPECT_EQ(*grid.find(octomap::OcTreeKey(9, 9, 9)), -4500);
}

}  // namespace
}  // namespace ccir_mapping::core::information
