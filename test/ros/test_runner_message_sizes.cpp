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

  const core::place_recognition::KeyframeWords words{robot,          7, 0, "0123456789abcdef",
                                                     {1, 5, 9, 300}, 42};
  EXPECT_EQ(serializedBytes(TeamMessage(words)),
            serializationLength(conversions::toKeyframeFeaturesMsg(sensor_header, words)));

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

  core::pose_graph::LoopClosureData loop;
  loop.robot_from = robot;
  loop.robot_to = "robot_c";
  loop.method = "fabmap";
  EXPECT_EQ(serializedBytes(TeamMessage(loop)),
            serializationLength(conversions::toLoopClosureMsg(loop)));

  auto scan = std::make_shared<core::routing::WireScan>();
  scan->robot = robot;
  scan->points.assign(1234, 0);
  EXPECT_EQ(serializedBytes(TeamMessage(std::shared_ptr<const core::routing::WireScan>(scan))),
            serializationLength(conversions::toSharedScanMsg(
                core::routing::WireScan(*scan), sensor_header.frame_id, robot + "/odom")));
}

}  // namespace
}  // namespace ccir_mapping
