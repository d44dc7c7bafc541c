// dynamic_reconfigure clamps to the .cfg bounds without telling the core: every value the .cfg
// allows must be valid in the core, and the .cfg defaults must equal the core defaults.
#include <gtest/gtest.h>

#include "ccir_mapping/BrokerConfig.h"
#include "ccir_mapping/PreprocessorConfig.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/routing/broker_params.h"

namespace ccir_mapping {
namespace {

bool rangeError(const std::vector<std::string>& errors, const std::string& name) {
  for (const auto& e : errors) {
    if (e.rfind(name + " = ", 0) == 0) return true;
  }
  return false;
}

#define CCIR_EXPECT_FIELD(Core, Config, field)                                        \
  do {                                                                                \
    EXPECT_EQ(Core{}.field, Config::__getDefault__().field) << #field " default";     \
    Core at_min, at_max;                                                              \
    at_min.field = Config::__getMin__().field;                                        \
    at_max.field = Config::__getMax__().field;                                        \
    EXPECT_FALSE(rangeError(at_min.validate(), #field)) << #field " at the .cfg min"; \
    EXPECT_FALSE(rangeError(at_max.validate(), #field)) << #field " at the .cfg max"; \
  } while (0)

TEST(ReconfigureBounds, Preprocessor) {
  using Core = core::preprocess::PreprocessorParams;
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, min_range_m);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, max_range_m);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, voxel_leaf_m);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, normal_radius_m);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, horizontal_normal_z);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, keyframe_distance_m);
  CCIR_EXPECT_FIELD(Core, PreprocessorConfig, keyframe_rotation_deg);
}

TEST(ReconfigureBounds, Broker) {
  using Core = core::routing::BrokerParams;
  CCIR_EXPECT_FIELD(Core, BrokerConfig, loop_closure_weight);
  CCIR_EXPECT_FIELD(Core, BrokerConfig, unknown_transform_factor);
  CCIR_EXPECT_FIELD(Core, BrokerConfig, fixed_rate_every_n);
}

}  // namespace
}  // namespace ccir_mapping
