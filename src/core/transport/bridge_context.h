// What the stages of the Bridge share (private to the transport library): the links, each one
// peer's session and socket, the bridge's clock, the io_context its thread runs and the mutex
// that guards the links. BridgeConnections dials, accepts, identifies and closes; BridgePump
// moves bytes between sockets and sessions; Bridge ties them to publish() and reports().
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <boost/asio.hpp>

#include "ccir_mapping/core/transport/bridge_stage.h"
#include "ccir_mapping/core/transport/token_bucket.h"

namespace ccir_mapping::core::transport {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Socket = std::shared_ptr<tcp::socket>;

/// One configured peer.
struct BridgeLink {
  PeerConfig config;
  /// This side dials (the other listens); else it waits to be dialled.
  bool dials = false;
  PeerSession session;
  Socket socket;                 // null while down
  std::uint64_t generation = 0;  // which connection a handler belongs to
  bool writing = false;
  double backoff_s = 0.0;
  double connected_at_s = 0.0;
  std::string address;
  /// Streams refused and connections ended inside a frame, by reason.
  std::map<std::string, std::uint64_t> refused;
  std::unique_ptr<asio::steady_timer> dial_timer;
  /// What the peer may make this side read: BridgePump::read waits for it.
  std::unique_ptr<TokenBucket> read_bucket;
  std::unique_ptr<asio::steady_timer> read_timer;
};

struct BridgeContext {
  BridgeContext(const BridgeParams& params, std::string own, BridgeStage::InboxHandler on_message,
                BridgeStage::LogHandler on_log, BridgeStage::Clock clock)
      : params(params),
        own(std::move(own)),
        on_message(std::move(on_message)),
        on_log(std::move(on_log)),
        clock(std::move(clock)) {}

  /// Seconds on the bridge's clock: the monotonic wall clock since start, or the given clock
  /// (mission time while replaying), which jumps when a replay starts or skips: the bridge's
  /// time does not, so a link is not found silent and no budget accrues across the jump.
  double now() const {
    if (!clock) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    const double reading = clock();
    if (std::isfinite(clock_s)) last_s += std::clamp(reading - clock_s, 0.0, kMaxClockStepS);
    clock_s = reading;
    return last_s;
  }
  static asio::steady_timer::duration after(double s) {
    return std::chrono::duration_cast<asio::steady_timer::duration>(
        std::chrono::duration<double>(std::max(0.0, s)));
  }
  void log(bool warning, const std::string& text) const {
    if (on_log) on_log(warning, text);
  }

  /// With a clock of unknown speed (mission time), a look at it advances the bridge's time by
  /// at most this much: a larger step is a jump, not time.
  static constexpr double kMaxClockStepS = 1.0;

  const BridgeParams params;
  const std::string own;
  const BridgeStage::InboxHandler on_message;
  const BridgeStage::LogHandler on_log;
  const BridgeStage::Clock clock;  // empty: steady time since start
  const std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  mutable double last_s = 0;     // the bridge's time: never back
  mutable double clock_s = NAN;  // the clock's reading at the last look

  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work{io.get_executor()};

  std::mutex mutex;  // everything below (the thread and publish() / reports())
  std::vector<std::unique_ptr<BridgeLink>> links;
};

}  // namespace ccir_mapping::core::transport
