// A short history of odometry poses, queried at scan stamps. Written here rather than taken from
// tf2::BufferCore, which does the same interpolation but takes ROS message types.
#pragma once

#include <deque>
#include <optional>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::preprocess {

class OdometryBuffer {
 public:
  /// Keeps samples no older than `horizon_s` behind the newest one.
  explicit OdometryBuffer(double horizon_s = 10.0) : horizon_(fromSeconds(horizon_s)) {}

  /// Adds a sample; returns false (and keeps nothing) when the stamp is not after the newest
  /// sample or the pose is not finite.
  bool add(Stamp stamp, const Pose3& pose);

  /// The pose at `stamp`: interpolated between the samples around it (linear in translation,
  /// slerp in rotation), or the nearest sample when it lies within `tolerance_s`.
  std::optional<Pose3> at(Stamp stamp, double tolerance_s) const;

  bool empty() const { return samples_.empty(); }
  std::optional<Stamp> newestStamp() const;
  void clear() { samples_.clear(); }

 private:
  struct Sample {
    Stamp stamp;
    Pose3 pose;
  };
  Stamp horizon_;
  std::deque<Sample> samples_;
};

}  // namespace ccir_mapping::core::preprocess
