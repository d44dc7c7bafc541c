#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ccir_mapping/core/information/key_codes.h"

namespace ccir_mapping::core::information {
namespace {

TEST(KeyCodes, PackRoundTripsAndOrdersByXThenYThenZ) {
  const octomap::OcTreeKey key(65535, 1, 32768);
  EXPECT_EQ(unpackKey(packKey(key)), key);
  EXPECT_LT(packKey({1, 65535, 65535}), packKey({2, 0, 0}));
  EXPECT_LT(packKey({1, 1, 65535}), packKey({1, 2, 0}));
}

TEST(KeyCodes, SortsByKeyStablyWithThePayloadAlong) {
  std::mt19937_64 rng(3);
  std::vector<std::uint64_t> codes;
  for (std::uint64_t i = 0; i < 5000; ++i) {
    // Few distinct keys, so that many share one; the payload numbers them in order.
    codes.push_back(packKey({static_cast<octomap::key_type>(rng() % 7),
                             static_cast<octomap::key_type>(rng() % 5),
                             static_cast<octomap::key_type>(rng() % 65536 % 3)}) |
                    i << 48);
  }
  std::vector<std::uint64_t> expected = codes;
  constexpr std::uint64_t kKey = (std::uint64_t{1} << 48) - 1;
  std::stable_sort(expected.begin(), expected.end(),
                   [](std::uint64_t a, std::uint64_t b) { return (a & kKey) < (b & kKey); });
  sortKeyCodes(codes);
  EXPECT_EQ(codes, expected);
}

}  // namespace
}  // namespace ccir_mapping::core::information
