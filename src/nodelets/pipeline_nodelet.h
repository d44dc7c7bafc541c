// Base of every ccir_mapping nodelet: typed configuration that fails fast, per-topic flow
// counters, and diagnostics that show both.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/common/mission_clock.h"
#include "ccir_mapping/core/common/periodic_schedule.h"
#include "ccir_mapping/ros/param_reader.h"

namespace ccir_mapping {

class PipelineNodelet : public nodelet::Nodelet {
 public:
  ~PipelineNodelet() override;

 protected:
  /// Loads and validates the private parameters into `settings` with ros_params::load. On any
  /// error it logs NODELET_FATAL naming each parameter, reports the errors on diagnostics and
  /// returns false: the nodelet must then stay inert (advertise and subscribe nothing).
  template <class Settings>
  bool loadSettings(Settings& settings) {
    ros_params::ParamReader reader(privateParams(), getPrivateNodeHandle().getNamespace());
    load(reader, settings);
    return reportSettings(reader, settings.frames.robot_name);
  }

  /// Loads another nodelet's settings of this robot (its private namespace `name` beside this
  /// one's, e.g. the Broker reads the Bridge's peers); false, leaving the defaults, when they
  /// do not validate (that nodelet reports why).
  template <class Settings>
  bool loadSiblingSettings(const std::string& name, Settings& settings) {
    const std::string ns = getNodeHandle().resolveName(name);
    XmlRpc::XmlRpcValue values;
    ros::param::get(ns, values);
    ros_params::ParamReader reader(values, ns);
    Settings loaded;
    load(reader, loaded);
    if (!reader.errors().empty()) return false;
    settings = loaded;
    return true;
  }

  /// A configuration error found after loadSettings (e.g. a file a parameter names): logs it as
  /// FATAL and reports it on diagnostics like an invalid parameter. The caller stays inert.
  void failConfiguration(const std::string& error);

  /// Counts messages (and bytes) that passed through a named input or output.
  void count(const std::string& flow, std::uint64_t bytes = 0);
  /// Adds CPU seconds spent in a named stage; diagnostics show each stage's total ("cpu s
  /// <stage>") and runs, the figures the CPU budget is measured with (bench_pipeline).
  void addCpu(const std::string& stage, double seconds);
  /// Runs `work` and adds the calling thread's CPU time to `stage`.
  template <class F>
  auto measured(const std::string& stage, F&& work) {
    struct Meter {
      PipelineNodelet& self;
      const std::string& stage;
      double start = core::threadCpuSeconds();
      ~Meter() { self.addCpu(stage, core::threadCpuSeconds() - start); }
    } meter{*this, stage};
    return work();
  }

  /// A periodic timer on the clock rates should follow: live, the monotonic wall clock
  /// (ros::Time follows the system clock, which may jump); replaying (/use_sim_time), a
  /// MissionClock, so that a replay at any speed does the same work per mission second and
  /// periodic work goes on once the replay has ended.
  template <class Callback>
  void createPeriodicTimer(double period_s, Callback callback) {
    ros::NodeHandle& nh = getNodeHandle();
    if (!ros::Time::isSimTime()) {
      timers_.push_back(nh.createSteadyTimer(
          ros::WallDuration(period_s), [callback](const ros::SteadyTimerEvent&) { callback(); }));
      return;
    }
    auto clock = std::make_shared<MissionClockReader>();
    auto schedule = std::make_shared<core::PeriodicSchedule>(period_s);
    timers_.push_back(
        nh.createSteadyTimer(ros::WallDuration(std::clamp(period_s / 4, 0.01, 0.1)),
                             [clock, schedule, callback](const ros::SteadyTimerEvent&) {
                               if (schedule->due(clock->now())) callback();
                             }));
  }
  /// Mission time (ros::Time) through a core::MissionClock, with the steady clock beside it.
  struct MissionClockReader {
    core::MissionClock clock;
    double now() { return clock.now(ros::Time::now().toSec(), ros::SteadyTime::now().toSec()); }
  };

  /// Adds a status line to the diagnostics (called from the diagnostics thread).
  virtual void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& /*status*/) {}

 private:
  XmlRpc::XmlRpcValue privateParams();
  bool reportSettings(const ros_params::ParamReader& reader, const std::string& robot_name);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);

  struct Flow {
    std::uint64_t messages = 0;
    std::uint64_t bytes = 0;
  };
  struct Cpu {
    std::uint64_t runs = 0;
    double seconds = 0.0;
  };
  std::mutex status_mutex_;
  std::map<std::string, Flow> flows_;
  std::map<std::string, Cpu> cpu_;
  std::vector<ros::SteadyTimer> timers_;
  std::vector<std::string> config_errors_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::SteadyTimer diagnostics_timer_;
};

}  // namespace ccir_mapping
