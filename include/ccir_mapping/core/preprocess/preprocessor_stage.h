// From placed scans to keyframes: every per-scan decision of the Preprocessor (stamp order, scans
// missing, enough usable points, keyframe or not) and the filtering of a keyframe, so that the
// nodelet only finds the pose and converts, and a ROS-free program runs the same stage.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/preprocess/keyframe_id_journal.h"
#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/preprocess/scan_gap_counter.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"

namespace ccir_mapping::core::preprocess {

class PreprocessorStage {
 public:
  using InputCloud = ScanPreprocessor::InputCloud;
  using OutputCloud = ScanPreprocessor::OutputCloud;

  /// What became of a scan offered with its pose.
  enum class Outcome { kKeyframe, kSkipped, kTooFewPoints, kStampNotIncreasing, kInvalidPose };

  struct Result {
    Outcome outcome = Outcome::kSkipped;
    /// The selector's decision (id, travel and rotation since the last keyframe).
    KeyframeSelector::Decision decision;
    /// The keyframe's points (kKeyframe only).
    OutputCloud::Ptr cloud;
    /// The range crop's counts for every scan that got that far; all counts for a keyframe.
    PreprocessStats stats;
    std::size_t usable_points = 0;
    /// Milliseconds spent filtering the keyframe (kKeyframe only).
    double filter_ms = 0.0;
    /// Why the scan was dropped (the last one; see dropped()), or what is odd about a scan:
    /// non-finite points in an unorganised cloud, a keyframe the filters left empty.
    std::vector<Notice> notices;

    /// kTooFewPoints, kStampNotIncreasing or kInvalidPose: the scan goes no further.
    bool dropped() const { return outcome != Outcome::kKeyframe && outcome != Outcome::kSkipped; }
  };

  /// A scan's arrival: refused (why first in notices) or accepted, with what to report about
  /// scans missing before it.
  struct Arrival {
    bool accepted = false;
    /// Scans the gap before it lost (ScanGapCounter).
    std::uint64_t missing_before = 0;
    std::vector<Notice> notices;
  };

  /// What the stage has done so far, for diagnostics.
  struct Totals {
    std::uint64_t keyframes = 0;
    std::size_t last_points_in = 0;
    std::size_t last_points_out = 0;
    double total_filter_ms = 0.0;
    double max_filter_ms = 0.0;
    /// Scans that never arrived, from gaps in the stamps of those that did.
    std::uint64_t missed_scans = 0;

    double meanFilterMs() const { return keyframes ? total_filter_ms / keyframes : 0.0; }
  };

  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit PreprocessorStage(const PreprocessorParams& params);

  /// A scan of `points` points as it arrives, before it waits for its pose. Refused: a stamp not
  /// after the previous arrival's (a bag replayed again), more than max_points points (its stamp
  /// still counts as arrived).
  Arrival arrive(Stamp stamp, std::size_t points);

  /// Offers a scan in the sensor frame with `sensor_pose`, the sensor frame in the
  /// gravity-aligned odometry frame at `stamp`. Scans come in stamp order.
  Result process(Stamp stamp, const Pose3& sensor_pose, const InputCloud& scan);

  /// Takes effect from the next scan; throws std::invalid_argument when invalid.
  void setParams(const PreprocessorParams& params);
  const PreprocessorParams& params() const { return preprocessor_.params(); }
  const Totals& totals() const { return totals_; }
  /// Keeps the keyframe ids unique across restarts: journaled in DIR (KeyframeIdJournal), with
  /// `resume` after those a previous run used there. Returns the first id when it resumed one.
  /// Call before any scan; throws std::runtime_error naming the file it cannot use.
  std::optional<KeyframeId> keepIdJournal(const std::string& dir, bool resume);

 private:
  static KeyframeSelector::Params selectorParams(const PreprocessorParams& params);

  ScanPreprocessor preprocessor_;
  KeyframeSelector selector_;
  ScanGapCounter gaps_;
  std::optional<KeyframeIdJournal> journal_;
  std::optional<Stamp> last_arrival_;
  Totals totals_;
};

}  // namespace ccir_mapping::core::preprocess
