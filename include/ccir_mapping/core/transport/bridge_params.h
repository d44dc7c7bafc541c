// Parameters of the bridge that carries topics between robots' ROS masters.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ccir_mapping::core::transport {

/// Control messages (features, offers, requests, receipts) always go before bulk ones (scans).
enum class Priority { kControl, kBulk };
constexpr std::string_view kPriorityChoices = "control | bulk";
std::optional<Priority> parsePriority(std::string_view text);
const char* toString(Priority priority);

enum class QueuePolicy { kFifo, kKeepLatest };
constexpr std::string_view kQueuePolicyChoices = "fifo | keep_latest";
std::optional<QueuePolicy> parseQueuePolicy(std::string_view text);

struct TopicPolicy {
  Priority priority = Priority::kControl;
  QueuePolicy queue = QueuePolicy::kFifo;
  /// Messages waiting longer than this are dropped before sending; 0 keeps them.
  double max_age_s = 0.0;
  /// Messages queued at most; a new one beyond it drops the oldest waiting.
  std::size_t max_queued = 100;
};

struct PeerConfig {
  /// The peer's robot name (its frames and topics are prefixed with it).
  std::string name;
  std::string host;
  int port = 0;
};

struct ForwardedTopic {
  /// Local topic, relative to the robot's namespace (e.g. "outbox/scans"); it arrives at the
  /// peer as "inbox/<name after outbox/>".
  std::string topic;
  TopicPolicy policy;
  /// Delivered exactly once across reconnects (acknowledged, resent); else best effort.
  bool reliable = true;
  /// zstd before sending (point clouds gain little; CPU on both ends).
  bool compress = false;
};

struct BridgeParams {
  /// TCP port this bridge accepts peers on; 0 = accept none (only connect out).
  int listen_port = 0;
  /// The local address it listens on: loopback unless the user names the radio's interface
  /// (or 0.0.0.0 for every interface), so that a robot is not reachable from every network it
  /// joins by default.
  std::string listen_address = "127.0.0.1";
  /// Shared secret of the team: frames are authenticated with it (HMAC-SHA256).
  std::string team_key;
  std::vector<PeerConfig> peers;
  std::vector<ForwardedTopic> topics;
  /// Bytes per second on each peer link, frame headers included.
  double budget_bytes_per_s = 150000.0;
  /// Bytes per second over all links together (the radio is shared).
  double total_budget_bytes_per_s = 150000.0;
  /// Token-bucket depth: the most bytes a link may send in one burst.
  int burst_bytes = 131072;
  /// Large messages are cut into fragments of at most this many bytes.
  int fragment_bytes = 65536;
  /// Largest message forwarded or accepted.
  int max_message_bytes = 16 << 20;
  /// Reconnection attempts back off from the first delay, doubling, to the last.
  double reconnect_min_s = 0.5;
  double reconnect_max_s = 10.0;
  /// A connection that carries nothing for this long is closed (keep-alives go every third).
  double peer_timeout_s = 10.0;
  /// Period of LinkStats.
  double stats_period_s = 1.0;

  std::vector<std::string> validate(const std::string& own_robot_name) const;
  /// The teammates' names, in the order of `peers`.
  std::vector<std::string> peerNames() const;
};

}  // namespace ccir_mapping::core::transport
