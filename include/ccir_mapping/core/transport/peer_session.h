// The bridge protocol with one peer, without sockets: messages in -> bytes to write, bytes read
// -> messages out. The nodelet moves the bytes over TCP; tests wire two sessions back to back.
//
// On each connection both sides first send HELLO (their robot name, their incarnation: a number
// drawn at start-up, and a nonce drawn for this connection) under the team key, and nothing else
// until the peer's HELLO has come: every later frame is authenticated with the connection's keys
// (linkKey of both nonces), so frames recorded from another connection are refused, and a HELLO
// takes effect (a new incarnation resets what was delivered) only once a frame under those keys
// has followed it. Then they announce their topics (TOPIC: name, type, md5, definition, latched,
// reliable, compressed) and send DATA. The receiver acknowledges reliable topics (ACK: highest
// sequence delivered); what the peer has not acknowledged when a connection drops is sent again
// on the next, and the receiver drops what it already delivered. A peer with a new incarnation
// has restarted: its sequences start again, and it is sent the latest message of each latched
// topic. A stream that fails the frame checks, skips HELLO or names another robot is refused.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
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
  /// Messages travel zstd-compressed (the link counts the compressed bytes).
  bool compressed = false;
  TopicPolicy policy;
};

struct Hello {
  std::string robot;
  std::uint64_t incarnation = 0;
  Nonce nonce{};
};
std::vector<std::uint8_t> encodeHello(const Hello& hello);
/// nullopt for a payload that is not a HELLO's.
std::optional<Hello> decodeHello(const std::vector<std::uint8_t>& payload);

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
  /// Names this run of the process (draw it at start-up); a peer seeing it change knows the
  /// sender restarted.
  std::uint64_t incarnation = 1;
};

struct SessionCounters {
  std::uint64_t bytes_received = 0;  // on the wire
  std::uint64_t messages_received = 0;
  /// When the last frame arrived (negative: never).
  double last_heard_s = -1.0;
  std::uint64_t dropped_not_connected = 0;  // unreliable messages offered with no link up
  std::uint64_t dropped_too_large = 0;      // above max_message_bytes
  /// Connections on which the peer came back as a new process (a new incarnation).
  std::uint64_t peer_restarts = 0;
};

class PeerSession {
 public:
  PeerSession(std::string own_robot, std::string peer_robot, std::string team_key,
              const SessionParams& params, double now_s);

  /// A local topic to forward (announced at once if connected); returns its id on the link.
  std::uint16_t addTopic(const TopicInfo& topic, double now_s);
  /// A message of a topic added before. While no connection is up, reliable messages wait
  /// for the next one and unreliable ones are dropped.
  void send(std::uint16_t topic, std::vector<std::uint8_t> message, double now_s);
  /// Shares a total budget with other links (LinkScheduler::shareBucket).
  void shareBucket(std::shared_ptr<TokenBucket> total) { scheduler_.shareBucket(std::move(total)); }

  /// A new connection: HELLO, the topic announcements and every unacknowledged reliable
  /// message go first; what was queued for the old connection is dropped (reliable messages
  /// are in the outbox).
  void connected(double now_s);
  /// The connection is gone.
  void disconnected();
  bool isConnected() const { return connected_; }
  /// Queues a tiny frame if nothing else is, so the peer can tell a quiet link from a dead one.
  void keepAlive(double now_s);
  /// Encoded frames the budget allows now (possibly none), at most `max_frames` of them (links
  /// sharing a total budget take turns a frame at a time).
  std::vector<std::uint8_t> output(double now_s, std::size_t max_frames = SIZE_MAX);
  /// Seconds until output() has something to send (infinity when nothing is queued).
  double outputDelay(double now_s) { return scheduler_.delay(now_s); }
  /// Bytes read from the connection; delivered messages are appended to `inbox`. False when
  /// the stream is refused: close the connection (reason()).
  bool input(const std::uint8_t* data, std::size_t size, double now_s,
             std::vector<InboxMessage>& inbox);

  const std::string& reason() const { return reason_; }
  /// Bytes read and not yet a whole frame: a connection closing with some left was truncated.
  std::size_t partialInputBytes() const { return decoder_.buffered(); }
  const LinkCounters& counters() const { return scheduler_.counters(); }
  const SessionCounters& sessionCounters() const { return counters_; }
  /// Messages (bytes) waiting to be sent in a class: queued on the connection, or with none up,
  /// the reliable ones the next connection will send.
  std::size_t queued(Priority priority) const {
    return connected_ ? scheduler_.queued(priority) : inOutbox(priority).first;
  }
  std::size_t queuedBytes(Priority priority) const {
    return connected_ ? scheduler_.queuedBytes(priority) : inOutbox(priority).second;
  }
  double availableTokens(double now_s) const { return scheduler_.availableTokens(now_s); }
  std::uint64_t duplicatesDropped() const { return filter_.duplicates(); }
  /// Reliable messages the peer never got: given up by its outbox bound, seen as gaps here.
  std::uint64_t missing() const { return filter_.missing(); }
  std::uint64_t givenUp() const { return outbox_.givenUp(); }

 private:
  static constexpr std::uint16_t kSessionTopic = 0;

  bool refuse(std::string reason);
  /// Messages and bytes of a class's reliable topics in the outbox.
  std::pair<std::size_t, std::size_t> inOutbox(Priority priority) const;
  void announce(std::uint16_t id, double now_s);
  /// A HELLO: checked, and the connection's keys derived; false when it is refused.
  bool greet(const std::vector<std::uint8_t>& payload, double now_s);
  /// What the peer's HELLO means, once a frame under the connection's key proved it fresh.
  void welcome(const Hello& hello, double now_s);

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
  /// Latched topics: the latest message sent, with its sequence.
  std::map<std::uint16_t, std::pair<std::uint64_t, std::vector<std::uint8_t>>> latched_;
  /// The peer's topics with the size of their announcements, bounded together in number and
  /// bytes (a topic's name, type and definition: a few KB).
  static constexpr std::size_t kMaxPeerTopics = 1024;
  static constexpr std::size_t kMaxPeerTopicBytes = 4 << 20;
  std::map<std::uint16_t, std::pair<TopicInfo, std::size_t>> peer_topics_;
  std::size_t peer_topic_bytes_ = 0;
  std::optional<std::uint64_t> peer_incarnation_;
  bool connected_ = false;
  bool peer_said_hello_ = false;
  /// This connection's nonce, whether our HELLO is out, the key of what we send (empty until
  /// the peer's HELLO), and the peer's HELLO until a frame under the connection's key follows.
  Nonce nonce_{};
  bool hello_sent_ = false;
  std::string out_key_;
  std::optional<Hello> unconfirmed_hello_;
  std::string reason_;
  SessionCounters counters_;
};

}  // namespace ccir_mapping::core::transport
