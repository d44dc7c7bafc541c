// PreprocessorParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"

namespace ccir_mapping::core::preprocess {
namespace {

using testing::mentions;

TEST(PreprocessorParams, DefaultsAreValid) { EXPECT_TRUE(PreprocessorParams{}.validate().empty()); }

TEST(PreprocessorParams, NamesEachInvalidValue) {
  PreprocessorParams p;
  p.voxel_leaf_m = 0.0;
  p.keyframe_rotation_deg = 181.0;
  p.odom_tolerance_s = std::nan("");
  const auto errors = p.validate();
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_TRUE(mentions(errors, "voxel_leaf_m = 0"));
  EXPECT_TRUE(mentions(errors, "keyframe_rotation_deg = 181"));
  EXPECT_TRUE(mentions(errors, "odom_tolerance_s = nan"));
}

TEST(PreprocessorParams, RangesMustBeOrdered) {
  PreprocessorParams p;
  p.min_range_m = 10.0;
  p.max_range_m = 5.0;
  EXPECT_TRUE(mentions(p.validate(), "max_range_m must be greater than min_range_m"));
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
