#include <gtest/gtest.h>

#include <random>
#include <set>
#include <tuple>

#include "ccir_mapping/core/information/key_bricks.h"

namespace ccir_mapping::core::information {
namespace {

/// Depth-first order of the octree: the first depth (from the root) at which two keys part
/// decides, by OctoMap's child index there.
bool beforeInTree(const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
  for (int depth = 15; depth >= 0; --depth) {
    const auto ca = octomap::computeChildIdx(a, depth);
    const auto cb = octomap::computeChildIdx(b, depth);
    if (ca != cb) return ca < cb;
  }
  return false;
}

using Reference = std::set<std::tuple<int, int, int>>;

void expectInTreeOrder(const std::vector<octomap::OcTreeKey>& keys, const Reference& reference) {
  ASSERT_EQ(keys.size(), reference.size());
  for (std::size_t i = 1; i < keys.size(); ++i) {
    ASSERT_TRUE(beforeInTree(keys[i - 1], keys[i])) << "at " << i;
  }
  for (const auto& key : keys) EXPECT_TRUE(reference.count({key[0], key[1], key[2]}));
}

TEST(KeyBricks, ListsEveryKeyOnceInTheTreesDepthFirstOrder) {
  KeyBricks set;
  Reference reference;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> anywhere(0, 65535);  // the whole key range: a key a brick
  std::uniform_int_distribution<int> near(32700, 32740);  // dense: many keys a brick
  for (int i = 0; i < 20000; ++i) {
    auto& d = i % 2 ? anywhere : near;
    const octomap::OcTreeKey key(d(rng), d(rng), d(rng));
    set.insert(key);
    set.insert(key);  // again: still once
    reference.emplace(key[0], key[1], key[2]);
  }
  expectInTreeOrder(set.inTreeOrder(), reference);
  const auto& [x, y, z] = *reference.begin();
  EXPECT_TRUE(set.contains(octomap::OcTreeKey(x, y, z)));
  EXPECT_EQ(set.contains(octomap::OcTreeKey(0, 0, 0)), reference.count({0, 0, 0}) > 0);
}

TEST(KeyBricks, LeavesOutTheKeysOfAnotherSet) {
  KeyBricks rays;
  KeyBricks ends;
  Reference reference;
  for (int x = 32760; x < 32790; ++x) {  // a line of cells through several bricks
    const octomap::OcTreeKey key(x, 32768, 32767);
    rays.insert(key);
    if (x % 7 == 0) {
      ends.insert(key);
    } else {
      reference.emplace(key[0], key[1], key[2]);
    }
  }
  ends.insert(octomap::OcTreeKey(1, 2, 3));  // a brick the rays do not reach
  expectInTreeOrder(rays.inTreeOrder(&ends), reference);
  EXPECT_TRUE(ends.contains(octomap::OcTreeKey(32767, 32768, 32767)));
  EXPECT_FALSE(ends.contains(octomap::OcTreeKey(32768, 32768, 32767)));
}

}  // namespace
}  // namespace ccir_mapping::core::information
