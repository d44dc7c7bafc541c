#include "ccir_mapping/core/transport/bridge_params.h"

#include <set>

#include <boost/asio/ip/address.hpp>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/transport/frame_codec.h"

namespace ccir_mapping::core::transport {

std::optional<Priority> parsePriority(std::string_view text) {
  if (text == "control") return Priority::kControl;
  if (text == "bulk") return Priority::kBulk;
  return std::nullopt;
}

const char* toString(Priority priority) {
  return priority == Priority::kControl ? "control" : "bulk";
}

std::optional<QueuePolicy> parseQueuePolicy(std::string_view text) {
  if (text == "fifo") return QueuePolicy::kFifo;
  if (text == "keep_latest") return QueuePolicy::kKeepLatest;
  return std::nullopt;
}

std::vector<std::string> BridgeParams::validate(const std::string& own_robot_name) const {
  ParamCheck check;
  check.inRange("listen_port", listen_port, 0, 65535);
  boost::system::error_code bad_address;
  boost::asio::ip::make_address(listen_address, bad_address);
  check.require(!bad_address, "listen_address '" + listen_address +
                                  "' is not an IPv4 or IPv6 address (e.g. 10.0.0.1, 0.0.0.0)");
  check.inRange("budget_bytes_per_s", budget_bytes_per_s, 1000.0, 1e9);
  check.inRange("total_budget_bytes_per_s", total_budget_bytes_per_s, 1000.0, 1e9);
  check.inRange("max_message_bytes", max_message_bytes, 1024, 1 << 30);
  check.inRange("reconnect_min_s", reconnect_min_s, 0.01, 3600.0);
  check.inRange("reconnect_max_s", reconnect_max_s, reconnect_min_s, 3600.0);
  check.inRange("peer_timeout_s", peer_timeout_s, 0.5, 3600.0);
  if (!peers.empty() || listen_port != 0) {
    check.require(team_key.size() >= 16,
                  "team_key must be at least 16 characters (the same secret on every robot) "
                  "when the bridge has peers or listens");
  }
  check.inRange("fragment_bytes", fragment_bytes, 1024, 1 << 20);
  check.inRange("burst_bytes", burst_bytes, 1024, 1 << 26);
  check.require(static_cast<std::size_t>(burst_bytes) >= wireBytes(fragment_bytes),
                "burst_bytes must be at least fragment_bytes + " + std::to_string(wireBytes(0)) +
                    ", or a fragment can never be sent");
  check.inRange("stats_period_s", stats_period_s, 0.05, 3600.0);

  std::set<std::string> names;
  for (std::size_t i = 0; i < peers.size(); ++i) {
    const PeerConfig& peer = peers[i];
    const std::string prefix = "peers[" + std::to_string(i) + "].";
    check.robotName(prefix + "name", peer.name);
    check.require(peer.name != own_robot_name,
                  prefix + "name = '" + peer.name + "' is this robot's own name");
    check.require(names.insert(peer.name).second,
                  prefix + "name = '" + peer.name + "' appears twice");
    check.require(!peer.host.empty(), prefix + "host is empty");
    check.inRange(prefix + "port", peer.port, 1, 65535);
  }
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const std::string& topic = topics[i].topic;
    const std::string name = "topics[" + std::to_string(i) + "].topic";
    check.require(
        topic.rfind("outbox/", 0) == 0 && topic.size() > 7,
        name + " = '" + topic + "' is not allowed: allowed relative topics under outbox/");
    const std::string prefix = "topics[" + std::to_string(i) + "].";
    check.inRange(prefix + "max_age_s", topics[i].policy.max_age_s, 0.0, 86400.0);
    check.inRange(prefix + "max_queued", static_cast<double>(topics[i].policy.max_queued), 1.0,
                  1e6);
  }
  return check.errors();
}

std::vector<std::string> BridgeParams::peerNames() const {
  std::vector<std::string> names;
  for (const PeerConfig& peer : peers) names.push_back(peer.name);
  return names;
}

}  // namespace ccir_mapping::core::transport
