// Counts scans that never arrived, from gaps in the stamps of those that did: a sensor queue
// that overflowed while the pipeline was busy, a driver or a bag that lost scans. roscpp drops
// the oldest message of a full subscriber queue without telling anyone; this is how the
// Preprocessor notices.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::preprocess {

class ScanGapCounter {
 public:
  /// The scan period is learnt as the lower quartile of the recent intervals (a spinning
  /// lidar's revolutions are regular; losses only lengthen intervals, even when a third of the
  /// scans are lost and half the intervals are long; jitter moves a few either way). Once
  /// kMinIntervals are known, a gap of more than 1.5 periods holds round(gap / period) - 1 missing
  /// scans. Returns those of this stamp's gap; stamps that do not increase count nothing (the
  /// caller refuses them).
  std::uint64_t add(Stamp stamp);

  std::uint64_t missed() const { return missed_; }
  /// The learnt period in nanoseconds, 0 before kMinIntervals intervals.
  Stamp period() const;

  static constexpr std::size_t kMinIntervals = 3;
  static constexpr std::size_t kWindow = 15;

 private:
  std::optional<Stamp> last_;
  std::array<Stamp, kWindow> recent_{};  // a ring of the last intervals
  std::size_t intervals_ = 0;
  std::uint64_t missed_ = 0;
};

}  // namespace ccir_mapping::core::preprocess
