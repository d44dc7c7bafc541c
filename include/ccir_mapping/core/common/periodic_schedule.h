// When periodic work is due on a clock that is looked at more often than the period (the
// nodelets' periodic work on the mission clock while replaying).
#pragma once

namespace ccir_mapping::core {

class PeriodicSchedule {
 public:
  explicit PeriodicSchedule(double period_s) : period_s_(period_s), next_s_(period_s) {}

  /// True once per period: at the first look at or after each due time; after a jump of the
  /// clock, at once and then a period on.
  bool due(double now_s) {
    if (now_s < next_s_) return false;
    // Due times do not drift with late looks; a jump past a whole period restarts them.
    next_s_ = now_s >= next_s_ + period_s_ ? now_s + period_s_ : next_s_ + period_s_;
    return true;
  }

 private:
  double period_s_;
  double next_s_;
};

}  // namespace ccir_mapping::core
