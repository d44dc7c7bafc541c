// BridgeParams: the defaults are valid, and each invalid value is reported with its name.
#include <gtest/gtest.h>

#include <cmath>

#include "../param_errors.h"
#include "ccir_mapping/core/transport/bridge_params.h"

namespace ccir_mapping::core::transport {
namespace {

using testing::mentions;

TEST(BridgeParams, DefaultsAreValid) { EXPECT_TRUE(BridgeParams{}.validate("robot_a").empty()); }

TEST(BridgeParams, NamesEachInvalidPeerAndTopic) {
  BridgeParams p;
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

TEST(BridgeParams, BurstMustHoldAFragment) {
  BridgeParams p;
  p.fragment_bytes = 65536;
  p.burst_bytes = 4096;
  EXPECT_TRUE(mentions(p.validate("robot_a"), "burst_bytes must be at least fragment_bytes"));
}

}  // namespace
}  // namespace ccir_mapping::core::transport
