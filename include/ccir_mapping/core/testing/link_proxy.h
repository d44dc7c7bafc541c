// A TCP relay on loopback that carries each connection through a LinkEmulator per direction
// (delay, jitter, loss, outages, rate), for tests and benchmarks of the bridge (netem is not
// available on these machines). It records when and how many bytes entered it each way, so a
// test can check the sender's rate independently of the sender, and it can
// cut every connection on demand.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ccir_mapping/core/testing/link_emulator.h"

namespace ccir_mapping::core::testing {

struct LinkProxyParams {
  /// Port to accept on (127.0.0.1); 0 picks a free one (port()).
  int listen_port = 0;
  std::string target_host = "127.0.0.1";
  int target_port = 0;
  /// The link, both ways (the way back uses seed + 1).
  LinkEmulatorParams link;
};

/// A TCP port on 127.0.0.1 that was free a moment ago (for tests and benchmarks that start
/// several listeners).
int freeLoopbackPort();

class LinkProxy {
 public:
  /// Throws std::invalid_argument for a bad link or target, std::runtime_error when the port
  /// cannot be opened.
  explicit LinkProxy(const LinkProxyParams& params);
  ~LinkProxy();
  LinkProxy(const LinkProxy&) = delete;
  LinkProxy& operator=(const LinkProxy&) = delete;

  int port() const;
  /// Closes every relayed connection now; new ones are accepted as before.
  void cut();
  /// Seconds since the proxy started and bytes, for each chunk that entered it from the
  /// connecting side (towards the target) or from the target (back).
  std::vector<std::pair<double, std::size_t>> forwarded(bool towards_target = true) const;
  std::size_t connections() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ccir_mapping::core::testing
