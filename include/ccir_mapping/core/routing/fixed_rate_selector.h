// The fixed-rate baseline: every n-th keyframe is sent, whatever it contains.
#pragma once

#include <cstdint>

namespace ccir_mapping::core::routing {

class FixedRateSelector {
 public:
  explicit FixedRateSelector(int every_n) { setEveryN(every_n); }

  /// True for the 1st, (n+1)-th, (2n+1)-th ... keyframe offered.
  bool select();

  void setEveryN(int every_n) { every_n_ = every_n < 1 ? 1 : every_n; }

 private:
  int every_n_ = 1;
  std::uint64_t offered_ = 0;
};

}  // namespace ccir_mapping::core::routing
