#include "ccir_mapping/core/preprocess/keyframe_selector.h"

namespace ccir_mapping::core::preprocess {

KeyframeSelector::Decision KeyframeSelector::offer(Stamp stamp, const Pose3& odom_pose) {
  Decision decision;
  if (!isValidPose(odom_pose)) {
    decision.outcome = Outcome::kInvalidPose;
    return decision;
  }
  if (last_stamp_ && stamp <= *last_stamp_) {
    decision.outcome = Outcome::kStampNotIncreasing;
    return decision;
  }
  const bool first = !last_stamp_.has_value();
  if (!first) travelled_m_ += (odom_pose.translation() - last_pose_.translation()).norm();
  last_stamp_ = stamp;
  last_pose_ = odom_pose;

  decision.travelled_m = travelled_m_;
  decision.rotated_rad =
      first ? 0.0
            : Eigen::AngleAxisd(keyframe_pose_.linear().transpose() * odom_pose.linear()).angle();
  if (!first && decision.travelled_m < params_.distance_m &&
      decision.rotated_rad < params_.rotation_rad) {
    decision.outcome = Outcome::kSkipped;
    return decision;
  }
  decision.outcome = Outcome::kKeyframe;
  decision.id = next_id_++;
  keyframe_pose_ = odom_pose;
  travelled_m_ = 0.0;
  return decision;
}

}  // namespace ccir_mapping::core::preprocess
