// A radio link in user space, for tests (netem is not available on these machines): when each
// chunk of a byte stream sent at some time arrives, given a rate, a delay with jitter, losses
// (a lost chunk arrives a retransmission timeout later, as TCP would deliver it) and outages
// (nothing arrives while the link is down). Seeded, so a test run can be repeated. Order is
// kept: a stream never overtakes itself.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace ccir_mapping::core::testing {

struct LinkEmulatorParams {
  double rate_bytes_per_s = 150000.0;
  double delay_s = 0.01;
  double jitter_s = 0.005;
  /// Share of chunks lost once (each delayed by retransmit_s).
  double loss = 0.0;
  double retransmit_s = 0.2;
  /// [start, end) times when the link carries nothing.
  std::vector<std::pair<double, double>> outages;
  std::uint64_t seed = 1;

  std::vector<std::string> validate() const;
};

class LinkEmulator {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit LinkEmulator(const LinkEmulatorParams& params);

  /// When a chunk of `bytes` handed to the link at `send_s` (non-decreasing) arrives.
  double arrival(std::size_t bytes, double send_s);
  /// Whether the link is in an outage at `t`.
  bool down(double t) const;

 private:
  /// The first time >= t the link is up.
  double upAt(double t) const;

  LinkEmulatorParams params_;
  std::mt19937_64 rng_;
  /// When the link finishes serialising what it was given so far.
  double busy_until_s_ = 0.0;
  double last_arrival_s_ = 0.0;
};

}  // namespace ccir_mapping::core::testing
