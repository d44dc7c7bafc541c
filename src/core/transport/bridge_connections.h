// The Bridge's connection management (private to the transport library): listening and
// accepting, telling who an accepted connection is by its first frame (an authenticated HELLO),
// dialling with exponential backoff, attaching a connection to its link and closing it. Of two
// robots the one whose name sorts first dials (a robot that does not listen dials everyone). A
// connection that has not said who it is is bounded in number, time and size; one that fails is
// refused and counted by reason; so is one from a robot whose link is up and still heard from
// (a replayed HELLO ends nothing). All with the context's mutex held, on the bridge's thread.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "bridge_context.h"
#include "bridge_pump.h"

namespace ccir_mapping::core::transport {

class BridgeConnections {
 public:
  BridgeConnections(BridgeContext& context, BridgePump& pump);

  /// Opens the listening socket (std::runtime_error naming the port if it cannot) and accepts.
  void listen();
  /// Dials every link this side dials.
  void dialAll();
  /// Ends a link's connection (see BridgePump::Close); a link this side dials is dialled again.
  void close(BridgeLink& link, const std::string& why, const std::string& refusal);
  /// Connections refused before they said who they are, by reason.
  const std::map<std::string, std::uint64_t>& refusedUnidentified() const {
    return refused_unidentified_;
  }

 private:
  void scheduleDial(BridgeLink& link);
  void dial(BridgeLink& link);
  void accept();
  /// Reads an accepted connection until its first frame names a configured peer.
  void identify(const Socket& socket, const std::shared_ptr<std::vector<std::uint8_t>>& bytes,
                const std::shared_ptr<asio::steady_timer>& deadline, bool first);
  /// Makes `socket` the link's connection; `first_bytes` (what came with the HELLO) go into its
  /// session, and what they complete into `inbox`.
  void attach(BridgeLink& link, const Socket& socket, const std::vector<std::uint8_t>& first_bytes,
              std::vector<InboxMessage>& inbox);

  BridgeContext& context_;
  BridgePump& pump_;
  tcp::acceptor acceptor_;
  std::map<std::string, std::uint64_t> refused_unidentified_;
  std::size_t unidentified_ = 0;
};

}  // namespace ccir_mapping::core::transport
