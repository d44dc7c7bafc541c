// Every core Params struct: the defaults are valid, and each invalid value is reported with the
// parameter's name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/transport/bridge_params.h"

namespace ccir_mapping::core {
namespace {

bool mentions(const std::vector<std::string>& errors, const std::string& name) {
  return std::any_of(errors.begin(), errors.end(),
                     [&](const std::string& e) { return e.rfind(name, 0) == 0; });
}

TEST(ParamsValidation, DefaultsAreValid) {
  EXPECT_TRUE(preprocess::PreprocessorParams{}.validate().empty());
  EXPECT_TRUE(place_recognition::MatcherParams{}.validate().empty());
  EXPECT_TRUE(backend::BackendParams{}.validate().empty());
  EXPECT_TRUE(information::MapperParams{}.validate().empty());
  EXPECT_TRUE(routing::BrokerParams{}.validate().empty());
  EXPECT_TRUE(transport::BridgeParams{}.validate("robot_a").empty());
}

TEST(ParamsValidation, Preprocessor) {
  preprocess::PreprocessorParams p;
  p.voxel_leaf_m = 0.0;
  p.keyframe_rotation_deg = 181.0;
  p.odom_tolerance_s = std::nan("");
  const auto errors = p.validate();
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_TRUE(mentions(errors, "voxel_leaf_m = 0"));
  EXPECT_TRUE(mentions(errors, "keyframe_rotation_deg = 181"));
  EXPECT_TRUE(mentions(errors, "odom_tolerance_s = nan"));
}

TEST(ParamsValidation, PreprocessorRangesMustBeOrdered) {
  preprocess::PreprocessorParams p;
  p.min_range_m = 10.0;
  p.max_range_m = 5.0;
  EXPECT_TRUE(mentions(p.validate(), "max_range_m must be greater than min_range_m"));
}

TEST(ParamsValidation, Matcher) {
  place_recognition::MatcherParams p;
  p.min_correspondences = -1;
  p.verification.min_inliers = 2;  // nested: one struct, one default, checked once
  EXPECT_TRUE(mentions(p.validate(), "min_correspondences = -1"));
  EXPECT_TRUE(mentions(p.validate(), "min_inliers = 2"));
  EXPECT_EQ(place_recognition::parseMatchMethod("histogram"),
            place_recognition::MatchMethod::kHistogram);
  EXPECT_FALSE(place_recognition::parseMatchMethod("FABMAP").has_value());
}

TEST(ParamsValidation, Backend) {
  backend::BackendParams p;
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
    const auto kernel = backend::parseRobustKernel(name);
    ASSERT_TRUE(kernel.has_value()) << name;
    EXPECT_STREQ(backend::toString(*kernel), name);
  }
}

TEST(ParamsValidation, Mapper) {
  information::MapperParams p;
  p.resolution_m = 3.0;
  EXPECT_TRUE(mentions(p.validate(), "resolution_m = 3"));
}

TEST(ParamsValidation, Broker) {
  routing::BrokerParams p;
  p.loop_closure_weight = 1.5;
  p.unknown_transform_factor = 0.0;
  p.fixed_rate_every_n = 0;
  const auto errors = p.validate();
  EXPECT_EQ(errors.size(), 3u);
  EXPECT_TRUE(mentions(errors, "loop_closure_weight = 1.5"));
  EXPECT_TRUE(mentions(errors, "unknown_transform_factor = 0"));
  EXPECT_TRUE(mentions(errors, "fixed_rate_every_n = 0"));
}

TEST(ParamsValidation, BridgePeersAndTopics) {
  transport::BridgeParams p;
  p.team_key = "a key of sixteen or more";
  p.peers = {
      {"robot_b", "10.0.0.2", 17001}, {"robot_b", "10.0.0.3", 17001}, {"robot_a", "", 70000}};
  p.topics.resize(2);
  p.topics[0].topic = "outbox/scans";
  p.topics[1].topic = "/tf";
  const auto errors = p.validate("robot_a");
  EXPECT_TRUE(mentions(errors, "peers[1].name = 'robot_b' appears twice"));
  EXPECT_TRUE(mentions(errors, "peers[2].name = 'robot_a' is this robot's own name"));
  EXPECT_TRUE(mentions(errors, "peers[2].host is empty"));
  EXPECT_TRUE(mentions(errors, "peers[2].port = 70000"));
  EXPECT_TRUE(mentions(errors, "topics[1].topic = '/tf' is not allowed"));
  EXPECT_EQ(errors.size(), 5u);
}

TEST(ParamsValidation, BridgeBurstMustHoldAFragment) {
  transport::BridgeParams p;
  p.fragment_bytes = 65536;
  p.burst_bytes = 4096;
  EXPECT_TRUE(mentions(p.validate("robot_a"), "burst_bytes must be at least fragment_bytes"));
}

}  // namespace
}  // namespace ccir_mapping::core
