// BackendParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/backend/backend_params.h"

namespace ccir_mapping::core::backend {
namespace {

using testing::mentions;

TEST(BackendParams, DefaultsAreValid) { EXPECT_TRUE(BackendParams{}.validate().empty()); }

TEST(BackendParams, NamesEachInvalidValueAndParsesTheKernel) {
  BackendParams p;
  EXPECT_TRUE(p.validate().empty());  // switch_prior_sigma 0 means auto
  p.switch_prior_sigma = -1.0;
  p.max_iterations = 0;
  p.min_team_inliers = 2;
  p.team_disagreement_m = 0.0;
  p.team_disagreement_deg = 200.0;
  const auto errors = p.validate();
  EXPECT_TRUE(mentions(errors, "team_disagreement_m = 0"));
  EXPECT_TRUE(mentions(errors, "team_disagreement_deg = 200"));
  EXPECT_TRUE(mentions(errors, "switch_prior_sigma = -1"));
  EXPECT_TRUE(mentions(errors, "min_team_inliers = 2"));
  EXPECT_TRUE(mentions(errors, "max_iterations = 0"));
  for (const char* name : {"switchable", "none", "cauchy", "huber", "dcs"}) {
    const auto kernel = pose_graph::parseRobustKernel(name);
    ASSERT_TRUE(kernel.has_value()) << name;
    EXPECT_STREQ(pose_graph::toString(*kernel), name);
  }
}

}  // namespace
}  // namespace ccir_mapping::core::backend
