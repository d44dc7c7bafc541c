// The Bridge's session pumping (private to the transport library): bytes read from a link's
// socket go into its session, the sessions' frames go out a frame per link in turn (the links
// share the radio's budget), and a silent link is closed or kept alive. All with the context's
// mutex held, on the bridge's thread.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "bridge_context.h"

namespace ccir_mapping::core::transport {

class BridgePump {
 public:
  /// Ends a link's connection: what went wrong, and a reason to count as a refusal ("" for
  /// none).
  using Close =
      std::function<void(BridgeLink&, const std::string& why, const std::string& refusal)>;

  BridgePump(BridgeContext& context, Close close);

  /// Bytes from the link's peer into its session, and what they completed into `inbox`; false
  /// (the link closed) when the session refused the stream.
  bool input(BridgeLink& link, const std::uint8_t* data, std::size_t n,
             std::vector<InboxMessage>& inbox);
  /// Reads the link's socket until its connection ends, delivering what arrives, no faster than
  /// its read bucket allows.
  void read(BridgeLink& link);
  /// Writes what the sessions may send now, a frame per link in turn, and wakes up again when
  /// the next frame may go.
  void pump();
  /// Every peer_timeout_s / 3: closes links silent for peer_timeout_s, keeps the others alive.
  void keepAlive();

 private:
  void write(BridgeLink& link, const std::shared_ptr<std::vector<std::uint8_t>>& bytes);

  BridgeContext& context_;
  Close close_;
  asio::steady_timer pump_timer_;
  asio::steady_timer keepalive_timer_;
  std::size_t turn_ = 0;  // the link that sends first in the next round
  double next_keepalive_s_ = 0;
};

}  // namespace ccir_mapping::core::transport
