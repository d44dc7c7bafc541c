#include "ccir_mapping/core/runner/keyframe_feed.h"

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/preprocess/lidar_scan_cloud.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/preprocess/preprocessor_stage.h"

namespace ccir_mapping::core::runner {

namespace {

struct Stopped {};  // thrown through Mission::record to end it early

}  // namespace

class KeyframeFeed::Sink final : public simulation::RecordingSink {
 public:
  Sink(KeyframeFeed& feed, const simulation::Mission& mission,
       const preprocess::PreprocessorParams& params)
      : feed_(feed),
        stage_(params),
        mount_(mission.sensorMount()),
        tolerance_s_(params.odom_tolerance_s) {}

  void odometry(const simulation::OdometrySample& sample) override {
    odometry_.add(sample.stamp, sample.odometry);
    truth_.add(sample.stamp, sample.truth);
  }

  void scan(const LidarScan& scan, Stamp published) override {
    const double published_s = toSeconds(published);
    const auto odom = odometry_.at(scan.stamp, tolerance_s_);
    const auto truth = truth_.at(scan.stamp, tolerance_s_);
    std::optional<SimKeyframe> keyframe;
    if (!odom || !truth || !stage_.arrive(scan.stamp, scan.points.size()).accepted) {
      ++dropped_;
    } else {
      const Pose3 sensor = *odom * mount_;
      auto result = stage_.process(scan.stamp, sensor, preprocess::toCloud(scan));
      if (result.dropped()) ++dropped_;
      if (result.outcome == preprocess::PreprocessorStage::Outcome::kKeyframe) {
        keyframe = SimKeyframe{scan.stamp,   published_s, result.decision,
                               result.cloud, sensor,      *truth * mount_};
      }
    }
    std::unique_lock<std::mutex> lock(feed_.mutex_);
    feed_.changed_.wait(lock, [&] { return feed_.stop_ || feed_.ready_.size() < feed_.capacity_; });
    if (feed_.stop_) throw Stopped{};
    if (keyframe) feed_.ready_.push_back(std::move(*keyframe));
    feed_.recorded_until_s_ = published_s;
    feed_.dropped_scans_ = dropped_;
    feed_.cpu_s_ = threadCpuSeconds();
    feed_.changed_.notify_all();
  }

 private:
  KeyframeFeed& feed_;
  preprocess::PreprocessorStage stage_;
  preprocess::OdometryBuffer odometry_, truth_;
  const Pose3 mount_;
  const double tolerance_s_;
  std::uint64_t dropped_ = 0;
};

KeyframeFeed::KeyframeFeed(const simulation::Mission& mission, int index,
                           const preprocess::PreprocessorParams& params, std::size_t capacity)
    : capacity_(std::max<std::size_t>(1, capacity)) {
  preprocess::PreprocessorStage check(params);  // throws for invalid parameters, on this thread
  thread_ = std::thread([this, &mission, index, params] { record(mission, index, params); });
}

KeyframeFeed::~KeyframeFeed() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void KeyframeFeed::record(const simulation::Mission& mission, int index,
                          const preprocess::PreprocessorParams& params) {
  std::exception_ptr error;
  try {
    Sink sink(*this, mission, params);
    mission.record(index, sink);
  } catch (const Stopped&) {
  } catch (...) {
    error = std::current_exception();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  error_ = error;
  done_ = true;
  cpu_s_ = threadCpuSeconds();
  changed_.notify_all();
}

std::vector<SimKeyframe> KeyframeFeed::takeUntil(double until_s) {
  std::vector<SimKeyframe> taken;
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    while (!ready_.empty() && ready_.front().published_s < until_s) {
      taken.push_back(std::move(ready_.front()));
      ready_.pop_front();
    }
    changed_.notify_all();
    if (error_) std::rethrow_exception(error_);
    if (done_ || recorded_until_s_ >= until_s) return taken;
    changed_.wait(lock);
  }
}

double KeyframeFeed::cpuSeconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cpu_s_;
}

std::uint64_t KeyframeFeed::droppedScans() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_scans_;
}

}  // namespace ccir_mapping::core::runner
