// MatcherParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"

namespace ccir_mapping::core::place_recognition {
namespace {

using testing::mentions;

TEST(MatcherParams, DefaultsAreValid) { EXPECT_TRUE(MatcherParams{}.validate().empty()); }

TEST(MatcherParams, NamesEachInvalidValueAndParsesTheMethod) {
  MatcherParams p;
  p.min_correspondences = -1;
  p.verification.min_inliers = 2;  // nested: one struct, one default, checked once
  EXPECT_TRUE(mentions(p.validate(), "min_correspondences = -1"));
  EXPECT_TRUE(mentions(p.validate(), "min_inliers = 2"));
  EXPECT_EQ(parseMatchMethod("histogram"), MatchMethod::kHistogram);
  EXPECT_FALSE(parseMatchMethod("FABMAP").has_value());
}

}  // namespace
}  // namespace ccir_mapping::core::place_recognition
