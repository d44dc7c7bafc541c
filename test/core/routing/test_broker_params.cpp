// BrokerParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/routing/broker_params.h"

namespace ccir_mapping::core::routing {
namespace {

using testing::mentions;

TEST(BrokerParams, DefaultsAreValid) { EXPECT_TRUE(BrokerParams{}.validate().empty()); }

TEST(BrokerParams, NamesEachInvalidValue) {
  BrokerParams p;
  p.loop_closure_weight = 1.5;
  p.unknown_transform_factor = 0.0;
  p.fixed_rate_every_n = 0;
  const auto errors = p.validate();
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_TRUE(mentions(errors, "loop_closure_weight = 1.5"));
  EXPECT_TRUE(mentions(errors, "unknown_transform_factor = 0"));
  EXPECT_TRUE(mentions(errors, "fixed_rate_every_n = 0"));
}

}  // namespace
}  // namespace ccir_mapping::core::routing
