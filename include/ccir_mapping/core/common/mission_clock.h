// The clock rates follow while replaying: mission time while it advances, so that a replay at
// any speed does the same per mission second; the wall clock while mission time stands still
// (before a replay starts, while it is paused, after it ended), so that what is queued still
// drains and periodic work still happens. Never goes back.
#pragma once

namespace ccir_mapping::core {

class MissionClock {
 public:
  /// Mission time that has not moved for `stall_s` wall seconds counts as standing still.
  explicit MissionClock(double stall_s = 0.5) : stall_s_(stall_s) {}

  /// Seconds since the first reading, from a mission-time and a monotonic wall-clock reading.
  double now(double mission_s, double wall_s) {
    if (!started_) {
      started_ = true;
      last_mission_s_ = mission_s;
      last_wall_s_ = moved_wall_s_ = wall_s;
      return value_s_;
    }
    if (mission_s != last_mission_s_) {
      if (mission_s > last_mission_s_) value_s_ += mission_s - last_mission_s_;
      last_mission_s_ = mission_s;  // a clock that went back is followed from where it is
      moved_wall_s_ = wall_s;
    } else if (wall_s > moved_wall_s_ + stall_s_) {
      const double from =
          last_wall_s_ > moved_wall_s_ + stall_s_ ? last_wall_s_ : moved_wall_s_ + stall_s_;
      if (wall_s > from) value_s_ += wall_s - from;
    }
    last_wall_s_ = wall_s;
    return value_s_;
  }

 private:
  double stall_s_;
  bool started_ = false;
  double last_mission_s_ = 0.0;
  double last_wall_s_ = 0.0;
  double moved_wall_s_ = 0.0;  // wall time when mission time last moved
  double value_s_ = 0.0;
};

}  // namespace ccir_mapping::core
