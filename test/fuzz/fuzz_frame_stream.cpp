// libFuzzer target: what a peer can send a robot's bridge. The stream starts as an honest peer's
// would (the HELLO handshake, topic announcements, messages on a reliable, a latched and a
// compressed topic) and continues with what the input dictates: raw bytes, frames built from the
// input and signed with the connection's key (so that the checks after the MAC are reached) or
// the team's, and reconnections. The receiving session must refuse or deliver, never crash, and
// deliver only on topics the peer announced.
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "ccir_mapping/core/transport/peer_session.h"

namespace transport = ccir_mapping::core::transport;
using transport::Nonce;

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

/// Bounds the fuzzer can reach (and that cost little to set up for every input).
transport::SessionParams smallBounds() {
  transport::SessionParams params;
  params.max_message_bytes = 1 << 16;
  params.max_unacknowledged_bytes = 1 << 18;
  return params;
}

/// The first frame of `bytes` (a side's first output: its HELLO) decoded under the team key.
Nonce helloNonce(const std::vector<std::uint8_t>& bytes) {
  transport::FrameDecoder decoder(kKey, 1 << 16);
  decoder.feed(bytes.data(), bytes.size());
  const auto frame = decoder.next();
  const auto hello = frame ? transport::decodeHello(frame->payload) : std::nullopt;
  if (!hello) std::abort();  // the harness's own failure
  return hello->nonce;
}

/// An honest robot_a connecting to `receiver`: the handshake and its first messages; returns the
/// key of what robot_a sends on this connection.
std::string honestConnection(transport::PeerSession& receiver, double now_s,
                             std::vector<transport::InboxMessage>& inbox, bool& open) {
  transport::PeerSession sender("robot_a", "robot_b", kKey, smallBounds(), now_s);
  // Compressed, but nothing is sent on it here: a zstd context per input would cost most of the
  // fuzzer's time; the input's own frames on it reach the decompressor.
  sender.addTopic(topic("inbox/scans", true, false, true), now_s);
  const auto map = sender.addTopic(topic("inbox/map", true, true, false), now_s);
  const auto stats = sender.addTopic(topic("inbox/stats", false, false, false), now_s);
  sender.connected(now_s);
  receiver.disconnected();
  receiver.connected(now_s);
  const auto hello = sender.output(now_s);
  open = receiver.input(hello.data(), hello.size(), now_s, inbox);
  const auto reply = receiver.output(now_s);
  std::vector<transport::InboxMessage> ignored;
  if (!open || !sender.input(reply.data(), reply.size(), now_s, ignored)) std::abort();
  sender.send(map, {1, 2, 3}, now_s);
  sender.send(stats, {4, 5}, now_s);
  const auto rest = sender.output(now_s + 10.0);
  open = receiver.input(rest.data(), rest.size(), now_s, inbox);
  return transport::linkKey(kKey, helloNonce(hello), helloNonce(reply));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  transport::PeerSession receiver("robot_b", "robot_a", kKey, smallBounds(), 0.0);
  receiver.addTopic(topic("inbox/requests", true, false, false), 0.0);
  std::vector<transport::InboxMessage> inbox;
  double now_s = 0.0;
  bool open = true;
  std::string key = honestConnection(receiver, now_s, inbox, open);
  for (int step = 0; open && step < 32 && input.remaining_bytes() > 0; ++step) {
    now_s += 0.01;
    std::vector<std::uint8_t> bytes;
    switch (input.ConsumeIntegralInRange<int>(0, 3)) {
      case 0:
        bytes = input.ConsumeBytes<std::uint8_t>(input.ConsumeIntegralInRange<std::size_t>(0, 512));
        break;
      case 1: {  // a frame under this connection's key (or, sometimes, the team's)
        transport::Frame frame;
        frame.type = static_cast<transport::FrameType>(input.ConsumeIntegral<std::uint8_t>() % 6);
        frame.flags = input.ConsumeIntegral<std::uint8_t>();
        frame.topic = input.ConsumeIntegralInRange<std::uint16_t>(0, 5);
        frame.sequence = input.ConsumeIntegral<std::uint64_t>();
        frame.fragments = input.ConsumeIntegralInRange<std::uint16_t>(1, 4);
        frame.fragment = input.ConsumeIntegralInRange<std::uint16_t>(0, frame.fragments - 1);
        const bool team_key = input.ConsumeIntegralInRange<int>(0, 7) == 0;
        frame.payload =
            input.ConsumeBytes<std::uint8_t>(input.ConsumeIntegralInRange<std::size_t>(0, 256));
        bytes = transport::encodeFrame(frame, team_key ? std::string(kKey) : key);
        break;
      }
      case 2:  // the peer reconnects
        key = honestConnection(receiver, now_s, inbox, open);
        continue;
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
