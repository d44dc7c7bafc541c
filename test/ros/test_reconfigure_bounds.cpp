// dynamic_reconfigure clamps to the .cfg bounds without telling the core: every value the .cfg
// allows must be valid in the core, the .cfg defaults must equal the core defaults, and every
// .cfg key must have an entry in the nodelet's table (and no entry a key the .cfg lacks).
#include <gtest/gtest.h>

#include <set>

#include "ccir_mapping/ros/reconfigure_tables.h"

namespace ccir_mapping::ros_params {
namespace {

bool rangeError(const std::vector<std::string>& errors, const std::string& name) {
  for (const auto& e : errors) {
    if (e.rfind(name + " = ", 0) == 0) return true;
  }
  return false;
}

template <class Config, class Params>
void expectTableMatchesCfg(const ReconfigureTable<Config, Params>& table) {
  std::set<std::string> cfg_keys, table_keys;
  for (const auto& description : Config::__getParamDescriptions__()) {
    cfg_keys.insert(description->name);
  }
  for (const auto& entry : table.entries()) {
    table_keys.insert(entry.name);
    Params from_default, at_min, at_max;
    entry.to_params(Config::__getDefault__(), from_default);
    std::ostringstream changed;
    entry.note_change(Params{}, from_default, changed);
    EXPECT_EQ(changed.str(), "") << entry.name << ": the .cfg default is not the core's";
    entry.to_params(Config::__getMin__(), at_min);
    entry.to_params(Config::__getMax__(), at_max);
    EXPECT_FALSE(rangeError(at_min.validate(), entry.name)) << entry.name << " at the .cfg min";
    EXPECT_FALSE(rangeError(at_max.validate(), entry.name)) << entry.name << " at the .cfg max";
  }
  EXPECT_EQ(cfg_keys, table_keys);
}

TEST(ReconfigureBounds, Preprocessor) { expectTableMatchesCfg(preprocessorReconfigure()); }

TEST(ReconfigureBounds, Broker) { expectTableMatchesCfg(brokerReconfigure()); }

TEST(ReconfigureTable, AppliesValidChangesAndNamesThem) {
  core::routing::BrokerParams current;
  BrokerConfig config = BrokerConfig::__getDefault__();
  config.fixed_rate_every_n = 7;
  const auto outcome = brokerReconfigure().apply(config, current);
  EXPECT_FALSE(outcome.error);
  EXPECT_EQ(outcome.params.fixed_rate_every_n, 7);
  EXPECT_EQ(outcome.params.loop_closure_weight, current.loop_closure_weight);
  EXPECT_EQ(outcome.changes, " fixed_rate_every_n 5 -> 7");
  EXPECT_EQ(brokerReconfigure().apply(config, outcome.params).changes, "");
}

TEST(ReconfigureTable, RefusesAnInvalidCombinationAndResetsTheConfig) {
  core::preprocess::PreprocessorParams current;
  PreprocessorConfig config = PreprocessorConfig::__getDefault__();
  // Each within its .cfg bounds, but not together: the core wants min < max.
  config.min_range_m = 20.0;
  config.max_range_m = 10.0;
  config.voxel_leaf_m = 0.2;
  const auto outcome = preprocessorReconfigure().apply(config, current);
  ASSERT_TRUE(outcome.error);
  EXPECT_NE(outcome.error->find("range"), std::string::npos) << *outcome.error;
  EXPECT_EQ(outcome.params.voxel_leaf_m, current.voxel_leaf_m);
  EXPECT_EQ(config.min_range_m, current.min_range_m);
  EXPECT_EQ(config.max_range_m, current.max_range_m);
  EXPECT_EQ(config.voxel_leaf_m, current.voxel_leaf_m);
  EXPECT_EQ(outcome.changes, "");
}

}  // namespace
}  // namespace ccir_mapping::ros_params
