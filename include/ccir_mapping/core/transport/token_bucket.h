// Token bucket on a caller-supplied monotonic clock: at most burst + rate * dt bytes leave in any
// window of dt seconds. The Bridge keeps one per peer link and one for the total.
#pragma once

#include <cstddef>

namespace ccir_mapping::core::transport {

class TokenBucket {
 public:
  /// Starts full. Throws std::invalid_argument unless rate > 0 and burst > 0.
  TokenBucket(double rate_bytes_per_s, double burst_bytes, double now_s);

  /// Takes `bytes` if that many tokens are there at `now_s` (a message larger than the burst
  /// can never pass: cut it into fragments first).
  bool tryConsume(std::size_t bytes, double now_s);
  bool canConsume(std::size_t bytes, double now_s) const;
  /// Seconds from `now_s` until `bytes` could pass (0 if now; infinite if above the burst).
  double delayFor(std::size_t bytes, double now_s) const;
  double tokens(double now_s) const;

  double rate() const { return rate_; }
  double burst() const { return burst_; }

 private:
  double rate_;
  double burst_;
  double tokens_;
  double last_s_;
};

}  // namespace ccir_mapping::core::transport
