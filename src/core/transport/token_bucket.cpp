#include "ccir_mapping/core/transport/token_bucket.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace ccir_mapping::core::transport {
namespace {

// A micro-byte of slack: delayFor()'s answer, added to a clock, may round just short.
constexpr double kSlackBytes = 1e-6;

}  // namespace

TokenBucket::TokenBucket(double rate_bytes_per_s, double burst_bytes, double now_s)
    : rate_(rate_bytes_per_s), burst_(burst_bytes), tokens_(burst_bytes), last_s_(now_s) {
  if (!(rate_ > 0) || !(burst_ > 0)) {
    throw std::invalid_argument("TokenBucket: rate and burst must be positive");
  }
}

double TokenBucket::tokens(double now_s) const {
  // A clock that steps back (it should not) refills nothing.
  return std::min(burst_, tokens_ + rate_ * std::max(0.0, now_s - last_s_));
}

bool TokenBucket::canConsume(std::size_t bytes, double now_s) const {
  return static_cast<double>(bytes) <= tokens(now_s) + kSlackBytes;
}

bool TokenBucket::tryConsume(std::size_t bytes, double now_s) {
  const double available = tokens(now_s);
  last_s_ = std::max(last_s_, now_s);
  tokens_ = available;
  if (!canConsume(bytes, now_s)) return false;
  tokens_ = std::max(0.0, tokens_ - static_cast<double>(bytes));
  return true;
}

double TokenBucket::delayFor(std::size_t bytes, double now_s) const {
  const double need = static_cast<double>(bytes);
  if (need > burst_) return std::numeric_limits<double>::infinity();
  return std::max(0.0, (need - tokens(now_s)) / rate_);
}

}  // namespace ccir_mapping::core::transport
