#include <gtest/gtest.h>

#include <random>
#include <set>
#include <tuple>

#include "ccir_mapping/core/information/flat_key_set.h"

namespace ccir_mapping::core::information {
namespace {

TEST(FlatKeySet, HoldsEachKeyOnceThroughGrowth) {
  FlatKeySet set(4);
  std::set<std::tuple<int, int, int>> reference;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> coordinate(32700, 32840);  // around OctoMap's centre
  for (int i = 0; i < 20000; ++i) {
    const octomap::OcTreeKey key(coordinate(rng), coordinate(rng), coordinate(rng) % 32770);
    const bool fresh = reference.emplace(key[0], key[1], key[2]).second;
    EXPECT_EQ(set.insert(key), fresh);
  }
  EXPECT_EQ(set.size(), reference.size());
  std::size_t visited = 0;
  set.forEach([&](const octomap::OcTreeKey& key) {
    ++visited;
    EXPECT_TRUE(reference.count({key[0], key[1], key[2]}));
  });
  EXPECT_EQ(visited, reference.size());
  EXPECT_TRUE(set.contains(octomap::OcTreeKey(std::get<0>(*reference.begin()),
                                              std::get<1>(*reference.begin()),
                                              std::get<2>(*reference.begin()))));
  EXPECT_FALSE(set.contains(octomap::OcTreeKey(0, 0, 0)));
  EXPECT_FALSE(set.contains(octomap::OcTreeKey(65535, 65535, 65535)));
}

}  // namespace
}  // namespace ccir_mapping::core::information
