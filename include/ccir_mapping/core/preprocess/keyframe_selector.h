// Decides which scans become keyframes from the odometry travelled since the last keyframe.
#pragma once

#include <optional>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::preprocess {

class KeyframeSelector {
 public:
  struct Params {
    double distance_m = 1.0;
    double rotation_rad = 0.26;
  };

  enum class Outcome { kKeyframe, kSkipped, kStampNotIncreasing, kInvalidPose };

  struct Decision {
    Outcome outcome = Outcome::kSkipped;
    /// Id of the new keyframe (valid for kKeyframe).
    KeyframeId id = 0;
    /// Path length travelled and rotation (angle of the relative rotation) since the last
    /// keyframe, including this scan.
    double travelled_m = 0.0;
    double rotated_rad = 0.0;
  };

  explicit KeyframeSelector(const Params& params) : params_(params) {}

  /// Offers the odometry pose of a scan. Stamps must increase strictly; a scan whose stamp does
  /// not, or whose pose is not finite, changes nothing.
  Decision offer(Stamp stamp, const Pose3& odom_pose);

  void setParams(const Params& params) { params_ = params; }
  KeyframeId nextId() const { return next_id_; }
  /// Numbers the keyframes from `id` on (a resumed robot continues its ids: KeyframeIdJournal).
  void startIdsAt(KeyframeId id) { next_id_ = id; }

 private:
  Params params_;
  KeyframeId next_id_ = 0;
  std::optional<Stamp> last_stamp_;
  Pose3 last_pose_ = Pose3::Identity();
  Pose3 keyframe_pose_ = Pose3::Identity();
  double travelled_m_ = 0.0;
};

}  // namespace ccir_mapping::core::preprocess
