// The bridge's network side (no ROS): one PeerSession per configured teammate, carried over TCP
// with Boost.Asio on a thread of its own, in two stages (src/core/transport): BridgeConnections
// listens on listen_port, dials (of two robots the one whose name sorts first; a robot that
// does not listen dials everyone) and redials with exponential backoff, and matches an accepted
// connection to its peer by its first frame, an authenticated HELLO; BridgePump moves bytes
// between sockets and sessions, the links sharing the total budget and taking turns a frame at a
// time, reads each peer no faster than twice the link's budget, and closes a link silent for
// peer_timeout_s. Nothing a peer sends can stop the thread: a refused stream closes its
// connection and is counted by reason, and one sending at line rate is held back by TCP.
// What arrives is republished through InboxPublishers, the other half of the Bridge nodelet's
// stage.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ccir_mapping/core/transport/bridge_params.h"
#include "ccir_mapping/core/transport/inbox_publishers.h"
#include "ccir_mapping/core/transport/peer_session.h"

namespace ccir_mapping::core::transport {

/// One link as LinkStats reports it.
struct LinkReport {
  std::string peer;
  std::string address;
  bool connected = false;
  LinkCounters sent;
  SessionCounters received;
  std::size_t queued_control = 0;
  std::size_t queued_bulk = 0;
  std::size_t queued_control_bytes = 0;
  std::size_t queued_bulk_bytes = 0;
  /// Bytes the link's token buckets (its own and the total) would let leave now.
  double available_tokens_bytes = 0.0;
  /// Messages dropped and streams refused, by reason.
  std::map<std::string, std::uint64_t> drops;
  /// Seconds on the bridge's clock since the peer was last heard (negative: never).
  double silent_s = -1.0;
  /// The bridge's clock at the report: what its budget follows, so rates are per its second.
  double at_s = 0.0;
};

class BridgeStage {
 public:
  using InboxHandler = std::function<void(const std::string& peer, InboxMessage message)>;
  /// A link came up or a peer restarted (false), or something went wrong (true): closed,
  /// refused, unresolvable.
  using LogHandler = std::function<void(bool warning, const std::string& text)>;

  /// A peer is read at most kReadShare times as fast as this side's budget_bytes_per_s lets it
  /// send, in bursts of kReadShare * burst_bytes + kReadChunkBytes: a teammate configured
  /// alike never meets the limit; one sending at line rate is held back by TCP's flow control,
  /// losing nothing, and cannot take the bridge's thread from the other links.
  static constexpr double kReadShare = 2.0;
  static constexpr std::size_t kReadChunkBytes = 65536;

  /// Seconds on the clock budgets, keep-alives, silence and queue ages follow.
  using Clock = std::function<double()>;

  /// Throws std::invalid_argument when params.validate(own_robot) reports errors.
  /// `on_message` and `on_log` run on the bridge's thread. Without a `clock` the bridge runs on
  /// the monotonic wall clock; with one (mission time while replaying) it follows that clock,
  /// never backwards, and looks at it every few milliseconds since it cannot know its speed.
  BridgeStage(const BridgeParams& params, const std::string& own_robot, InboxHandler on_message,
              LogHandler on_log, Clock clock = {});
  ~BridgeStage();
  BridgeStage(const BridgeStage&) = delete;
  BridgeStage& operator=(const BridgeStage&) = delete;

  /// Opens the listening socket (std::runtime_error naming the port if it cannot) and starts
  /// the thread.
  void start();
  /// A local message for every peer (thread-safe). The first message of a topic name fixes its
  /// type; later ones of another md5 are dropped ("type_changed") and false is returned.
  /// With `only_peer` the message goes to that peer alone (none if it is not configured).
  bool publish(const TopicInfo& topic, std::vector<std::uint8_t> message,
               const std::string& only_peer = {});
  /// Thread-safe snapshot; the last entry (peer "") counts connections refused before they said
  /// who they are, if any.
  std::vector<LinkReport> reports();

 private:
  struct Impl;  // Asio stays out of this header
  std::unique_ptr<Impl> impl_;
};

}  // namespace ccir_mapping::core::transport
