// A teammate that has the team key but misbehaves, against robot_a's Bridge
// (bridge_rogue_peer.test): it announces a topic outside inbox/ ("../tf") and one without a type,
// then a proper one, and sends a message on each. Only the proper one may be republished; the
// others are dropped and counted. Then a frame with a broken MAC: the link is refused and counted
// by reason, and the Bridge carries on.
#include <gtest/gtest.h>

#include <array>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <std_msgs/String.h>
#include <boost/asio.hpp>

#include "ccir_mapping/LinkStats.h"
#include "ccir_mapping/core/transport/peer_session.h"
#include "wait_for.h"

namespace ccir_mapping {
namespace {

namespace transport = core::transport;
using testing::waitFor;

std::vector<std::uint8_t> serialise(const std::string& text) {
  std_msgs::String msg;
  msg.data = text;
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(msg));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, msg);
  return bytes;
}

transport::TopicInfo stringTopic(const std::string& name) {
  transport::TopicInfo t;
  t.name = name;
  t.type = ros::message_traits::DataType<std_msgs::String>::value();
  t.md5 = ros::message_traits::MD5Sum<std_msgs::String>::value();
  t.definition = ros::message_traits::Definition<std_msgs::String>::value();
  return t;
}

TEST(BridgeRoguePeer, BadTopicsAreDroppedAndCountedTheGoodOneArrives) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const int port = pnh.param("bridge_port", 0);
  const std::string key = pnh.param<std::string>("team_key", "");
  std::vector<std::string> received;
  ros::Subscriber good = nh.subscribe<std_msgs::String>(
      "inbox/robot_b/good", 10,
      [&](const std_msgs::String::ConstPtr& m) { received.push_back(m->data); });
  double dropped = 0.0;
  ros::Subscriber diagnostics = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& array) {
        for (const auto& status : array->status) {
          if (status.name.find("bridge: flow") == std::string::npos) continue;
          for (const auto& entry : status.values) {
            if (entry.key == "dropped from robot_b messages") dropped = std::stod(entry.value);
          }
        }
      });
  LinkStats::ConstPtr link;
  ros::Subscriber stats =
      nh.subscribe<LinkStats>("link_stats", 10, [&](const LinkStats::ConstPtr& m) {
        if (m->peer == "robot_b") link = m;
      });
  ASSERT_TRUE(waitFor([&] { return stats.getNumPublishers() > 0; }, 30.0)) << "no bridge";

  // robot_b, with the key, connects to robot_a's bridge.
  transport::PeerSession rogue("robot_b", "robot_a", key, transport::SessionParams{}, 0.0);
  transport::TopicInfo no_type = stringTopic("inbox/no_type");
  no_type.type.clear();
  no_type.md5.clear();
  const auto outside = rogue.addTopic(stringTopic("../tf"), 0.0);
  const auto typeless = rogue.addTopic(no_type, 0.0);
  const auto proper = rogue.addTopic(stringTopic("inbox/good"), 0.0);
  rogue.connected(0.0);
  rogue.send(outside, serialise("outside"), 0.0);
  rogue.send(typeless, serialise("typeless"), 0.0);
  rogue.send(proper, serialise("hello"), 0.0);
  boost::asio::io_context io;
  boost::asio::ip::tcp::socket socket(io);
  socket.connect({boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)});
  // The handshake: its HELLO, robot_a's, then the rest under the connection's key.
  boost::asio::write(socket, boost::asio::buffer(rogue.output(0.0)));
  std::vector<std::uint8_t> rest;
  while (rest.empty()) {
    std::array<std::uint8_t, 4096> reply;
    const std::size_t n = socket.read_some(boost::asio::buffer(reply));
    std::vector<transport::InboxMessage> ignored;
    ASSERT_TRUE(rogue.input(reply.data(), n, 0.0, ignored)) << rogue.reason();
    rest = rogue.output(0.0);
  }
  boost::asio::write(socket, boost::asio::buffer(rest));

  EXPECT_TRUE(waitFor([&] { return !received.empty(); }, 10.0)) << "the proper topic";
  EXPECT_TRUE(waitFor([&] { return dropped == 2.0; }, 10.0)) << "dropped: " << dropped;
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& t : topics) {
    EXPECT_EQ(t.name.find("tf"), std::string::npos) << t.name;
    EXPECT_EQ(t.name.find("no_type"), std::string::npos) << t.name;
  }

  // A frame whose MAC does not match: refused, counted, the link closed.
  transport::Frame frame;
  frame.type = transport::FrameType::kData;
  frame.topic = proper;
  frame.sequence = 2;
  frame.payload = serialise("forged");
  auto forged = transport::encodeFrame(frame, key);
  forged.back() ^= 1;
  boost::asio::write(socket, boost::asio::buffer(forged));
  ASSERT_TRUE(waitFor(
      [&] {
        if (!link) return false;
        for (std::size_t i = 0; i < link->drop_reasons.size(); ++i) {
          if (link->drop_reasons[i] == "refused: bad mac" && link->drop_counts[i] == 1) return true;
        }
        return false;
      },
      10.0));
  EXPECT_FALSE(link->connected);
  EXPECT_EQ(received, std::vector<std::string>{"hello"}) << "nothing forged arrived";
}

}  // namespace
}  // namespace ccir_mapping

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "bridge_rogue_peer_check");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
