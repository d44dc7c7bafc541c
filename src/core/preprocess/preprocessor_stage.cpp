#include "ccir_mapping/core/preprocess/preprocessor_stage.h"

#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdio>

namespace ccir_mapping::core::preprocess {

PreprocessorStage::PreprocessorStage(const PreprocessorParams& params)
    : preprocessor_(params), selector_(selectorParams(params)) {}

KeyframeSelector::Params PreprocessorStage::selectorParams(const PreprocessorParams& params) {
  return {params.keyframe_distance_m, params.keyframe_rotation_deg * M_PI / 180.0};
}

std::optional<KeyframeId> PreprocessorStage::keepIdJournal(const std::string& dir, bool resume) {
  journal_.emplace(dir, resume);
  selector_.startIdsAt(journal_->first());
  return journal_->resumed() ? std::optional(journal_->first()) : std::nullopt;
}

void PreprocessorStage::setParams(const PreprocessorParams& params) {
  preprocessor_ = ScanPreprocessor(params);
  selector_.setParams(selectorParams(params));
}

namespace {

const Notice kStampNotIncreasing{
    "stamp not increasing",
    "stamp not after the previous scan (a bag replayed again? restart the pipeline)"};

std::string format(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* format, ...) {
  char text[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof(text), format, args);
  va_end(args);
  return text;
}

}  // namespace

PreprocessorStage::Arrival PreprocessorStage::arrive(Stamp stamp, std::size_t points) {
  Arrival arrival;
  if (last_arrival_ && stamp <= *last_arrival_) {
    arrival.notices.push_back(kStampNotIncreasing);
    return arrival;
  }
  last_arrival_ = stamp;
  arrival.missing_before = gaps_.add(stamp);
  totals_.missed_scans = gaps_.missed();
  if (arrival.missing_before > 0) {
    arrival.notices.push_back(
        {"missing scans",
         format("%lu scan(s) missing before %.3f (%lu so far): the sensor queue overflowed while "
                "the pipeline was busy, or the driver or bag lost them; replay slower (rosbag "
                "play -r) if this machine cannot keep up",
                static_cast<unsigned long>(arrival.missing_before), double(stamp) * 1e-9,
                static_cast<unsigned long>(totals_.missed_scans))});
  }
  arrival.accepted = points <= static_cast<std::size_t>(params().max_points);
  if (!arrival.accepted) {
    arrival.notices.insert(
        arrival.notices.begin(),
        {"too many points", format("%zu points, more than max_points %d (a merged map or another "
                                   "sensor's topic?)",
                                   points, params().max_points)});
  }
  return arrival;
}

PreprocessorStage::Result PreprocessorStage::process(Stamp stamp, const Pose3& sensor_pose,
                                                     const InputCloud& scan) {
  Result result;
  // Enough usable points before the scan may take a keyframe's place.
  result.usable_points = preprocessor_.usablePoints(scan, &result.stats);
  const PreprocessStats& counted = result.stats;
  if (scan.height == 1 && counted.not_finite > 0) {
    result.notices.push_back(
        {"not finite", format("%zu of %zu points are NaN, infinite or zero in an unorganised "
                              "cloud (expected only in organised ones); they are skipped",
                              counted.not_finite, counted.points_in)});
  }
  if (result.usable_points < static_cast<std::size_t>(params().min_points)) {
    result.outcome = Outcome::kTooFewPoints;
    result.notices.push_back(
        {"too few points",
         format("only %zu of %zu points are finite and within [%g, %g] m (min_points %d)",
                result.usable_points, counted.points_in, params().min_range_m, params().max_range_m,
                params().min_points)});
    return result;
  }
  result.decision = selector_.offer(stamp, sensor_pose);
  switch (result.decision.outcome) {
    case KeyframeSelector::Outcome::kSkipped:
      result.outcome = Outcome::kSkipped;
      return result;
    case KeyframeSelector::Outcome::kStampNotIncreasing:
      result.outcome = Outcome::kStampNotIncreasing;
      result.notices.push_back(kStampNotIncreasing);
      return result;
    case KeyframeSelector::Outcome::kInvalidPose:
      result.outcome = Outcome::kInvalidPose;
      result.notices.push_back({"pose not finite", "its pose is not finite"});
      return result;
    case KeyframeSelector::Outcome::kKeyframe:
      break;
  }
  result.outcome = Outcome::kKeyframe;
  try {
    if (journal_) journal_->use(result.decision.id);
  } catch (const std::exception& e) {  // the keyframe still goes out
    result.notices.push_back(
        {"journal", std::string(e.what()) + ": a restart with resume may reuse keyframe ids"});
  }
  const auto start = std::chrono::steady_clock::now();
  result.stats = {};
  result.cloud = preprocessor_.process(scan, upInFrame(sensor_pose), &result.stats);
  result.filter_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (result.cloud->empty()) {
    const PreprocessStats& s = result.stats;
    result.notices.push_back(
        {"empty keyframe",
         format("keyframe %lu has no point left after preprocessing (%zu in range, %zu without a "
                "normal, %zu horizontal, %zu outside the slice)",
                static_cast<unsigned long>(result.decision.id),
                s.points_in - s.not_finite - s.out_of_range, s.without_normal, s.horizontal,
                s.outside_slice)});
  }
  ++totals_.keyframes;
  totals_.last_points_in = result.stats.points_in;
  totals_.last_points_out = result.stats.points_out;
  totals_.total_filter_ms += result.filter_ms;
  totals_.max_filter_ms = std::max(totals_.max_filter_ms, result.filter_ms);
  return result;
}

}  // namespace ccir_mapping::core::preprocess
