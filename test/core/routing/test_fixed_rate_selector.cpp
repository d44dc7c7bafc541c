#include <gtest/gtest.h>

#include "ccir_mapping/core/routing/fixed_rate_selector.h"

namespace ccir_mapping::core::routing {
namespace {

TEST(FixedRateSelector, SelectsEveryNth) {
  FixedRateSelector selector(3);
  std::vector<bool> picks;
  for (int i = 0; i < 7; ++i) picks.push_back(selector.select());
  EXPECT_EQ(picks, (std::vector<bool>{true, false, false, true, false, false, true}));
}

TEST(FixedRateSelector, NonPositiveMeansEveryKeyframe) {
  FixedRateSelector selector(0);
  EXPECT_TRUE(selector.select());
  EXPECT_TRUE(selector.select());
}

}  // namespace
}  // namespace ccir_mapping::core::routing
