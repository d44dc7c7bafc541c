// The pose prior of a loop-closure search: where a keyframe may be, relative to this robot's
// places, given odometry and the loop closures accepted so far. A search inside the gate
// verifies a few candidates; one without a prior goes through the VerificationQueue.
#pragma once

#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <string>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::place_recognition {

/// An accepted loop closure between one of this robot's keyframes and another keyframe (its
/// own, or a teammate's), seen as the pose of the other keyframe's odometry frame in this
/// robot's: from it, the other robot's later keyframes are predicted in this robot's frame.
struct GateAnchor {
  Pose3 other_in_own = Pose3::Identity();
  /// Odometry path of this robot at its keyframe of the closure.
  double own_path_m = 0.0;
  /// The other keyframe's position in its odometry frame, and its path when known (own loops;
  /// a teammate's path is not known here, so its distance in a straight line stands for it).
  Eigen::Vector3d other_position = Eigen::Vector3d::Zero();
  std::optional<double> other_path_m;
};

/// A keyframe of a candidate pair: its odometry position and path length when known.
struct GateKeyframe {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::optional<double> path_m;
};

class PoseGate {
 public:
  struct Params {
    /// Odometry drifts by at most this per metre of path since the anchor (either side).
    double drift_m_per_m = 0.1;
    /// ... and at most this in all (an allowance larger than the mine admits everything).
    double max_drift_m = 60.0;
    /// Two keyframes farther apart than this never show one place.
    double reach_m = 20.0;
    /// Anchors kept per other robot, the newest.
    std::size_t max_anchors = 8;
  };
  /// The drift allowance before any path: what the odometry check after verification allows too.
  static constexpr double kBaseAllowanceM = 1.0;

  explicit PoseGate(Params params) : params_(params) {}

  /// An accepted closure with `other` ("" for this robot's own loops).
  void addAnchor(const std::string& other, const GateAnchor& anchor);
  /// `other`'s anchors, oldest first (empty when none).
  const std::deque<GateAnchor>& anchors(const std::string& other) const;

  /// How far apart `own` (a keyframe of this robot) and `other` (in the anchor's other frame)
  /// are predicted under `anchor`, as a share of what the gate allows: reach_m plus the drift
  /// allowance of both sides since the anchor. At most 1: they may show one place.
  double ratio(const GateAnchor& anchor, const GateKeyframe& own, const GateKeyframe& other) const;
  /// A radius around an anchor's prediction holding every keyframe it may admit.
  double searchRadius() const { return params_.reach_m + params_.max_drift_m; }

 private:
  Params params_;
  std::map<std::string, std::deque<GateAnchor>> anchors_;
};

}  // namespace ccir_mapping::core::place_recognition
