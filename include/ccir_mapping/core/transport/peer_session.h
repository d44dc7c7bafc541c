// The bridge protocol with one peer, without sockets: messages in -> bytes to write, bytes read
// -> messages out. The nodelet moves the bytes over TCP; tests wire two sessions back to back.
//
// On each connection both sides first send HELLO (their robot name) and announce their topics
// (TOPIC: name, type, md5, definition, latched, reliable), then DATA. The receiver acknowledges
// reliable topics (ACK: highest sequence delivered); what the peer has not acknowledged when a
// connection drops is sent again on the next, and the receiver drops what it already delivered.
// A stream that fails the frame checks, skips HELLO or names another robot is refused.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ccir_mapping/core/transport/frame_codec.h"
#include "ccir_mapping/core/transport/link_scheduler.h"
#include "ccir_mapping/core/transport/message_fragments.h"
#include "ccir_mapping/core/transport/reliable_outbox.h"
#include "ccir_mapping/core/transport/sequence_filter.h"

namespace ccir_mapping::core::transport {

struct TopicInfo {
  /// The name the peer republishes it under (e.g. "inbox/scans"), and the ROS type.
  std::string name;
  std::string type;
  std::string md5;
  std::string definition;
  bool latched = false;
  bool reliable = true;
  TopicPolicy policy;
};

struct InboxMessage {
  TopicInfo topic;
  std::vector<std::uint8_t> bytes;
};

struct SessionParams {
  double budget_bytes_per_s = 150000.0;
  std::size_t burst_bytes = 131072;
  std::size_t fragment_bytes = 65536;
  /// Largest message accepted (and frame payload), and unacknowledged bytes kept.
  std::size_t max_message_bytes = 16 << 20;
  std::size_t max_unacknowledged_bytes = 64 << 20;
};

class PeerSession {
 public:
  PeerSession(std::string own_robot, std::string peer_robot, std::string team_key,
              const SessionParams& params, double now_s);

  /// A local topic to forward (announced at once if connected); returns its id on the link.
  std::uint16_t addTopic(const TopicInfo& topic, double now_s);
  /// A message of a topic added before.
  void send(std::uint16_t topic, std::vector<std::uint8_t> message, double now_s);

  /// A new connection: HELLO, the topic announcements and every unacknowledged reliable
  /// message go first; what was queued for the old connection is dropped (reliable messages
  /// are in the outbox).
  void connected(double now_s);
  /// Encoded frames the budget allows now (possibly none).
  std::vector<std::uint8_t> output(double now_s);
  /// Seconds until output() has something to send (infinity when nothing is queued).
  double outputDelay(double now_s) { return scheduler_.delay(now_s); }
  /// Bytes read from the connection; delivered messages are appended to `inbox`. False when
  /// the stream is refused: close the connection (reason()).
  bool input(const std::uint8_t* data, std::size_t size, double now_s,
             std::vector<InboxMessage>& inbox);

  const std::string& reason() const { return reason_; }
  const LinkCounters& counters() const { return scheduler_.counters(); }
  std::uint64_t duplicatesDropped() const { return filter_.duplicates(); }

 private:
  static constexpr std::uint16_t kSessionTopic = 0;

  bool refuse(std::string reason);
  void announce(std::uint16_t id, double now_s);
  void handle(const Frame& frame, double now_s, std::vector<InboxMessage>& inbox);

  std::string own_;
  std::string peer_;
  std::string key_;
  SessionParams params_;
  LinkScheduler scheduler_;
  FrameDecoder decoder_;
  Reassembler reassembler_;
  ReliableOutbox outbox_;
  SequenceFilter filter_;
  std::vector<TopicInfo> topics_;  // id - 1
  std::map<std::uint16_t, TopicInfo> peer_topics_;
  bool connected_ = false;
  bool peer_said_hello_ = false;
  std::string reason_;
};

}  // namespace ccir_mapping::core::transport
