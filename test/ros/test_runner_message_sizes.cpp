// The runner's links carry each message as many bytes as roscpp serialises for the message the
// nodelets publish (core/runner/team_message.h): checked here against roscpp itself.
#include <gtest/gtest.h>

#include "ccir_mapping/core/runner/team_message.h"
#include "ccir_mapping/ros/conversions.h"

namespace ccir_mapping {
namespace {

using core::runner::serializedBytes;
using core::runner::TeamMessage;
using ros::serialization::serializationLength;

TEST(RunnerMessageSizes, EveryOutboxMessageHasItsRosSerialisedSize) {
  const std::string robot = "robot_ab";  // names of any length
  std_msgs::Header sensor_header;
  sensor_header.frame_id = robot + "/velodyne";  // a keyframe's header, as the Preprocessor's

  core::runner::WordsMessage words{robot, 7, 0, "0123456789abcdef", {1, 5, 9, 300}, 42};
  EXPECT_EQ(serializedBytes(TeamMessage(words)),
            serializationLength(conversions::toKeyframeFeaturesMsg(
                sensor_header, robot, words.id, words.vocabulary_hash, words.words,
                words.descriptor_count)));

  core::routing::Offer offer{robot, "robot_c", 3, {}};
  for (int k = 0; k < 3; ++k) offer.scans.push_back({core::KeyframeId(k), {}, 4, 60000, 0.5});
  EXPECT_EQ(serializedBytes(TeamMessage(offer)),
            serializationLength(conversions::toOfferMsg(offer, robot + "/map")));

  const core::routing::Request request{"robot_c", robot, 3, {1, 2}};
  EXPECT_EQ(serializedBytes(TeamMessage(request)),
            serializationLength(conversions::toRequestMsg(request)));
  const core::routing::Receipt receipt{"robot_c", robot, {1, 2, 3}};
  EXPECT_EQ(serializedBytes(TeamMessage(receipt)),
            serializationLength(conversions::toReceiptMsg(receipt)));

  core::backend::LoopClosureData loop;
  loop.robot_from = robot;
  loop.robot_to = "robot_c";
  loop.method = "fabmap";
  EXPECT_EQ(serializedBytes(TeamMessage(loop)),
            serializationLength(conversions::toLoopClosureMsg(loop)));

  auto scan = std::make_shared<core::runner::WireScan>();
  scan->robot = robot;
  scan->points.assign(1234, 0);
  SharedScan shared;  // as conversions::toSharedScan fills it from a keyframe
  shared.header = sensor_header;
  shared.robot = robot;
  shared.odom_frame = robot + "/odom";
  shared.points = scan->points;
  EXPECT_EQ(serializedBytes(TeamMessage(std::shared_ptr<const core::runner::WireScan>(scan))),
            serializationLength(shared));
}

}  // namespace
}  // namespace ccir_mapping
