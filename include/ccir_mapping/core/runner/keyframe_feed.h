// One simulated robot's keyframes: its recording (core/simulation) goes through the
// Preprocessor's stage (preprocess::PreprocessorStage, placed by the recorded odometry as the
// Preprocessor places a scan) on a thread of its own, which stays at most `capacity` keyframes
// ahead of the reader. Only keyframes are kept, so a long mission's scans never pile up.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::runner {

struct SimKeyframe {
  Stamp stamp = 0;
  /// Mission seconds at which the driver published the scan (the end of its sweep).
  double published_s = 0.0;
  preprocess::KeyframeSelector::Decision decision;
  pcl::PointCloud<pcl::PointXYZINormal>::ConstPtr cloud;
  /// The sensor in the odometry frame: as odometry puts it, and in truth.
  Pose3 odom_pose = Pose3::Identity();
  Pose3 true_pose = Pose3::Identity();
};

class KeyframeFeed {
 public:
  /// Starts recording robot `index` of `mission` (which must outlive the feed). Throws
  /// std::invalid_argument when params.validate() reports errors.
  KeyframeFeed(const simulation::Mission& mission, int index,
               const preprocess::PreprocessorParams& params, std::size_t capacity = 4);
  /// Stops the recording where it is.
  ~KeyframeFeed();
  KeyframeFeed(const KeyframeFeed&) = delete;
  KeyframeFeed& operator=(const KeyframeFeed&) = delete;

  /// The keyframes published before `until_s` (mission seconds) not taken yet, in order; waits
  /// until the recording has passed `until_s` or ended. Rethrows what the recording threw.
  std::vector<SimKeyframe> takeUntil(double until_s);
  /// CPU seconds the recording and preprocessing have used so far.
  double cpuSeconds() const;
  /// Scans the stage dropped (too few points, no odometry to place them).
  std::uint64_t droppedScans() const;

 private:
  class Sink;
  void record(const simulation::Mission& mission, int index,
              const preprocess::PreprocessorParams& params);

  const std::size_t capacity_;
  mutable std::mutex mutex_;  // guards what follows
  std::condition_variable changed_;
  std::deque<SimKeyframe> ready_;
  double recorded_until_s_ = -1.0;
  bool done_ = false;
  bool stop_ = false;
  std::exception_ptr error_;
  double cpu_s_ = 0.0;
  std::uint64_t dropped_scans_ = 0;
  std::thread thread_;  // last: starts once everything above is constructed
};

}  // namespace ccir_mapping::core::runner
