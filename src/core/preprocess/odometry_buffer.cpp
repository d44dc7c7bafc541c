#include "ccir_mapping/core/preprocess/odometry_buffer.h"

#include <algorithm>
#include <cstdlib>

namespace ccir_mapping::core::preprocess {

bool OdometryBuffer::add(Stamp stamp, const Pose3& pose) {
  if (!isValidPose(pose) || (!samples_.empty() && stamp <= samples_.back().stamp)) return false;
  samples_.push_back({stamp, pose});
  while (samples_.front().stamp < stamp - horizon_) samples_.pop_front();
  return true;
}

std::optional<Stamp> OdometryBuffer::newestStamp() const {
  if (samples_.empty()) return std::nullopt;
  return samples_.back().stamp;
}

std::optional<Pose3> OdometryBuffer::at(Stamp stamp, double tolerance_s) const {
  if (samples_.empty()) return std::nullopt;
  const Stamp tolerance = fromSeconds(tolerance_s);
  const auto after = std::lower_bound(samples_.begin(), samples_.end(), stamp,
                                      [](const Sample& s, Stamp t) { return s.stamp < t; });
  if (after != samples_.end() && after->stamp == stamp) return after->pose;
  if (after != samples_.begin() && after != samples_.end()) {
    const Sample& a = *(after - 1);
    const Sample& b = *after;
    // Interpolate only across gaps an odometry source really leaves (at most 2 tolerances).
    if (b.stamp - a.stamp <= 2 * tolerance) {
      const double s =
          static_cast<double>(stamp - a.stamp) / static_cast<double>(b.stamp - a.stamp);
      Pose3 pose = Pose3::Identity();
      pose.translation() = (1.0 - s) * a.pose.translation() + s * b.pose.translation();
      pose.linear() = Eigen::Quaterniond(a.pose.linear())
                          .slerp(s, Eigen::Quaterniond(b.pose.linear()))
                          .normalized()
                          .toRotationMatrix();
      return pose;
    }
  }
  // Outside the buffer (or across a gap): the nearest sample, if close enough.
  const Sample* nearest = nullptr;
  if (after != samples_.end()) nearest = &*after;
  if (after != samples_.begin()) {
    const Sample& before = *(after - 1);
    if (!nearest || stamp - before.stamp < nearest->stamp - stamp) nearest = &before;
  }
  if (std::llabs(nearest->stamp - stamp) <= tolerance) return nearest->pose;
  return std::nullopt;
}

}  // namespace ccir_mapping::core::preprocess
