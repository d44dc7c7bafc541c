// MapperParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/information/mapper_params.h"

namespace ccir_mapping::core::information {
namespace {

using testing::mentions;

TEST(MapperParams, DefaultsAreValid) { EXPECT_TRUE(MapperParams{}.validate().empty()); }

TEST(MapperParams, NamesEachInvalidValue) {
  MapperParams p;
  p.resolution_m = 3.0;
  EXPECT_TRUE(mentions(p.validate(), "resolution_m = 3"));
}

}  // namespace
}  // namespace ccir_mapping::core::information
