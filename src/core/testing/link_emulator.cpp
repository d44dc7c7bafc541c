#include "ccir_mapping/core/testing/link_emulator.h"

#include <algorithm>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::testing {

std::vector<std::string> LinkEmulatorParams::validate() const {
  ParamCheck check;
  check.inHalfOpenRange("rate_bytes_per_s", rate_bytes_per_s, 0.0, 1e12);
  check.inRange("delay_s", delay_s, 0.0, 60.0);
  check.inRange("jitter_s", jitter_s, 0.0, 60.0);
  check.inRange("loss", loss, 0.0, 1.0);
  check.inRange("retransmit_s", retransmit_s, 0.0, 60.0);
  for (const auto& [start, end] : outages) {
    check.require(start <= end, "outages: each [start, end) must have start <= end");
  }
  return check.errors();
}

LinkEmulator::LinkEmulator(const LinkEmulatorParams& params)
    : params_(validated(params)), rng_(params.seed) {}

bool LinkEmulator::down(double t) const {
  return std::any_of(params_.outages.begin(), params_.outages.end(),
                     [t](const auto& o) { return o.first <= t && t < o.second; });
}

double LinkEmulator::upAt(double t) const {
  // Outages may touch or overlap: step past each one that holds t until none does.
  for (bool moved = true; moved;) {
    moved = false;
    for (const auto& [start, end] : params_.outages) {
      if (start <= t && t < end) {
        t = end;
        moved = true;
      }
    }
  }
  return t;
}

double LinkEmulator::arrival(std::size_t bytes, double send_s) {
  // Serialise at the rate once the link is free and up, then fly for delay + jitter.
  const double start = upAt(std::max(send_s, busy_until_s_));
  busy_until_s_ = start + static_cast<double>(bytes) / params_.rate_bytes_per_s;
  std::uniform_real_distribution<double> jitter(-params_.jitter_s, params_.jitter_s);
  std::bernoulli_distribution lost(params_.loss);
  double t = busy_until_s_ + std::max(0.0, params_.delay_s + jitter(rng_));
  if (lost(rng_)) t += params_.retransmit_s;
  // A stream keeps its order, and nothing arrives during an outage.
  last_arrival_s_ = upAt(std::max(t, last_arrival_s_));
  return last_arrival_s_;
}

}  // namespace ccir_mapping::core::testing
