// libFuzzer target: what a peer can send a robot's bridge. The stream starts as an honest peer's
// would (HELLO, topic announcements, messages on a reliable, a latched and a compressed topic)
// and continues with what the input dictates: raw bytes, frames built from the input and signed
// with the team key (so that the checks after the MAC are reached), the honest prefix replayed,
// and reconnections. The receiving session must refuse or deliver, never crash, and deliver only
// on topics the peer announced.
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "ccir_mapping/core/transport/peer_session.h"

namespace transport = ccir_mapping::core::transport;

namespace {

constexpr char kKey[] = "fuzz-team-key";

transport::TopicInfo topic(const char* name, bool reliable, bool latched, bool compressed) {
  transport::TopicInfo t;
  t.name = name;
  t.type = "ccir_mapping/Keyframe";
  t.md5 = "0123456789abcdef0123456789abcdef";
  t.definition = "uint64 id\n";
  t.reliable = reliable;
  t.latched = latched;
  t.compressed = compressed;
  return t;
}

/// An honest peer's first bytes on a new connection.
std::vector<std::uint8_t> honestStart() {
  transport::PeerSession sender("robot_a", "robot_b", kKey, transport::SessionParams{}, 0.0);
  const auto scans = sender.addTopic(topic("inbox/scans", true, false, true), 0.0);
  const auto map = sender.addTopic(topic("inbox/map", true, true, false), 0.0);
  const auto stats = sender.addTopic(topic("inbox/stats", false, false, false), 0.0);
  sender.connected(0.0);
  sender.send(scans, std::vector<std::uint8_t>(600, 7), 0.0);
  sender.send(map, {1, 2, 3}, 0.0);
  sender.send(stats, {4, 5}, 0.0);
  return sender.output(10.0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::uint8_t> start = honestStart();
  FuzzedDataProvider input(data, size);
  transport::SessionParams params;
  params.max_message_bytes = 1 << 16;  // small bounds, so that the fuzzer reaches them
  params.max_unacknowledged_bytes = 1 << 18;
  transport::PeerSession receiver("robot_b", "robot_a", kKey, params, 0.0);
  receiver.addTopic(topic("inbox/requests", true, false, false), 0.0);
  receiver.connected(0.0);
  std::vector<transport::InboxMessage> inbox;
  double now_s = 0.0;
  bool open = receiver.input(start.data(), start.size(), now_s, inbox);
  for (int step = 0; open && step < 32 && input.remaining_bytes() > 0; ++step) {
    now_s += 0.01;
    std::vector<std::uint8_t> bytes;
    switch (input.ConsumeIntegralInRange<int>(0, 4)) {
      case 0:
        bytes = input.ConsumeBytes<std::uint8_t>(input.ConsumeIntegralInRange<std::size_t>(0, 512));
        break;
      case 1: {
        transport::Frame frame;
        frame.type = static_cast<transport::FrameType>(input.ConsumeIntegral<std::uint8_t>() % 6);
        frame.flags = input.ConsumeIntegral<std::uint8_t>();
        frame.topic = input.ConsumeIntegralInRange<std::uint16_t>(0, 5);
        frame.sequence = input.ConsumeIntegral<std::uint64_t>();
        frame.fragments = input.ConsumeIntegralInRange<std::uint16_t>(1, 4);
        frame.fragment = input.ConsumeIntegralInRange<std::uint16_t>(0, frame.fragments - 1);
        frame.payload =
            input.ConsumeBytes<std::uint8_t>(input.ConsumeIntegralInRange<std::size_t>(0, 256));
        bytes = transport::encodeFrame(frame, kKey);
        break;
      }
      case 2:  // the honest start again: a replay on the same connection
        bytes = start;
        break;
      case 3:  // the peer reconnects and starts over
        receiver.disconnected();
        receiver.connected(now_s);
        bytes = start;
        break;
      default:
        receiver.output(now_s);  // acknowledgements, keep-alives
        continue;
    }
    open = receiver.input(bytes.data(), bytes.size(), now_s, inbox);
  }
  for (const transport::InboxMessage& message : inbox) {
    if (message.topic.name.rfind("inbox/", 0) != 0) std::abort();  // only announced topics
  }
  return 0;
}
