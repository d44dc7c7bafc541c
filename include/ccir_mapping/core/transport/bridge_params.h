// Parameters of the bridge that carries topics between robots' ROS masters.
#pragma once

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
  Priority priority = Priority::kControl;
};

struct BridgeParams {
  /// TCP port this bridge accepts peers on; 0 = accept none (only connect out).
  int listen_port = 0;
  std::vector<PeerConfig> peers;
  std::vector<ForwardedTopic> topics;
  /// Bytes per second on each peer link, frame headers included.
  double budget_bytes_per_s = 150000.0;
  /// Token-bucket depth: the most bytes a link may send in one burst.
  int burst_bytes = 131072;
  /// Large messages are cut into fragments of at most this many bytes.
  int fragment_bytes = 65536;
  /// Period of LinkStats.
  double stats_period_s = 1.0;

  std::vector<std::string> validate(const std::string& own_robot_name) const;
};

}  // namespace ccir_mapping::core::transport
