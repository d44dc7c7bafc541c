#include "ccir_mapping/core/preprocess/scan_gap_counter.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace ccir_mapping::core::preprocess {

Stamp ScanGapCounter::period() const {
  const std::size_t n = std::min(intervals_, kWindow);
  if (n < kMinIntervals) return 0;
  std::array<Stamp, kWindow> sorted = recent_;
  std::nth_element(sorted.begin(), sorted.begin() + n / 4, sorted.begin() + n);
  return sorted[n / 4];
}

std::uint64_t ScanGapCounter::add(Stamp stamp) {
  if (last_ && stamp <= *last_) return 0;
  const std::optional<Stamp> last = std::exchange(last_, stamp);
  if (!last) return 0;
  const Stamp interval = stamp - *last;
  std::uint64_t missing = 0;
  const Stamp p = period();
  if (p > 0 && 2 * interval > 3 * p) {
    missing = static_cast<std::uint64_t>(
        std::llround(static_cast<double>(interval) / static_cast<double>(p)) - 1);
  }
  recent_[intervals_++ % kWindow] = interval;
  missed_ += missing;
  return missing;
}

}  // namespace ccir_mapping::core::preprocess
