#include "ccir_mapping/core/preprocess/keyframe_stage.h"

#include <algorithm>
#include <chrono>

namespace ccir_mapping::core::preprocess {

KeyframeStage::KeyframeStage(const PreprocessorParams& params)
    : preprocessor_(params), selector_(selectorParams(params)) {}

KeyframeSelector::Params KeyframeStage::selectorParams(const PreprocessorParams& params) {
  return {params.keyframe_distance_m, params.keyframe_rotation_deg * M_PI / 180.0};
}

void KeyframeStage::setParams(const PreprocessorParams& params) {
  preprocessor_ = ScanPreprocessor(params);
  selector_.setParams(selectorParams(params));
}

bool KeyframeStage::arrive(Stamp stamp, std::uint64_t* missing_before) {
  *missing_before = 0;
  if (last_arrival_ && stamp <= *last_arrival_) return false;
  last_arrival_ = stamp;
  *missing_before = gaps_.add(stamp);
  totals_.missed_scans = gaps_.missed();
  return true;
}

KeyframeStage::Result KeyframeStage::process(Stamp stamp, const Pose3& sensor_pose,
                                             const InputCloud& scan) {
  Result result;
  // Enough usable points before the scan may take a keyframe's place.
  result.usable_points = preprocessor_.usablePoints(scan, &result.stats);
  if (result.usable_points < static_cast<std::size_t>(params().min_points)) {
    result.outcome = Outcome::kTooFewPoints;
    return result;
  }
  result.decision = selector_.offer(stamp, sensor_pose);
  switch (result.decision.outcome) {
    case KeyframeSelector::Outcome::kSkipped:
      result.outcome = Outcome::kSkipped;
      return result;
    case KeyframeSelector::Outcome::kStampNotIncreasing:
      result.outcome = Outcome::kStampNotIncreasing;
      return result;
    case KeyframeSelector::Outcome::kInvalidPose:
      result.outcome = Outcome::kInvalidPose;
      return result;
    case KeyframeSelector::Outcome::kKeyframe:
      break;
  }
  result.outcome = Outcome::kKeyframe;
  const auto start = std::chrono::steady_clock::now();
  result.stats = {};
  result.cloud = preprocessor_.process(scan, upInFrame(sensor_pose), &result.stats);
  result.filter_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  ++totals_.keyframes;
  totals_.last_points_in = result.stats.points_in;
  totals_.last_points_out = result.stats.points_out;
  totals_.total_filter_ms += result.filter_ms;
  totals_.max_filter_ms = std::max(totals_.max_filter_ms, result.filter_ms);
  return result;
}

}  // namespace ccir_mapping::core::preprocess
