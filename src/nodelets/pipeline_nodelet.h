// Base of every ccir_mapping nodelet: typed configuration that fails fast, per-topic flow
// counters, and diagnostics that show both.
#pragma once

#include <algorithm>
#include <cstdarg>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <boost/function.hpp>

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/common/mission_clock.h"
#include "ccir_mapping/core/common/periodic_schedule.h"
#include "ccir_mapping/ros/param_reader.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_table.h"

namespace ccir_mapping {

/// Every callback of a nodelet (subscriptions, timers, dynamic_reconfigure, diagnostics) runs on
/// its single-threaded queue (getNodeHandle, getPrivateNodeHandle), one at a time: state only
/// those callbacks touch needs no lock. Threads of a nodelet's own (a worker, a rebuild, the
/// bridge's sockets) do.
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

  /// The settings of another nodelet of this robot, named `name` (this nodelet's parameter
  /// `key`), e.g. the Broker reads its Bridge's peers. nullopt, after failConfiguration naming
  /// `key`, when that nodelet has no parameters (none of that name is launched); the defaults,
  /// with a warning, when they do not validate (that nodelet reports why).
  template <class Settings>
  std::optional<Settings> siblingSettings(const std::string& key, const std::string& name) {
    const std::string ns = getNodeHandle().resolveName(name);
    XmlRpc::XmlRpcValue values;
    if (!ros::param::get(ns, values)) {
      failConfiguration(key + ": no nodelet named " + ns + " (it has no parameters)");
      return std::nullopt;
    }
    ros_params::ParamReader reader(values, ns);
    Settings settings;
    load(reader, settings);
    if (reader.errors().empty()) return settings;
    NODELET_WARN("the parameters in %s are invalid (its nodelet says why): using defaults",
                 ns.c_str());
    return Settings{};
  }

  /// A configuration error found after loadSettings (e.g. a file a parameter names): logs it as
  /// FATAL and reports it on diagnostics like an invalid parameter. The caller stays inert (one
  /// found once running calls stopWork first).
  void failConfiguration(const std::string& error);
  /// Ends every subscription and periodic timer: the nodelet does nothing more.
  void stopWork() {
    subscribers_.clear();
    timers_.clear();
  }

  /// Runs `open`, which opens a stage's journal in save_dir and throws what it cannot do. False
  /// when it could not and `resume` was asked for (failConfiguration: the caller stays inert);
  /// without `resume` the error is logged and the nodelet runs unjournaled.
  template <class Open>
  bool openJournal(bool resume, Open open) {
    try {
      open();
    } catch (const std::exception& e) {
      if (resume) {
        failConfiguration(std::string(e.what()) + " (save_dir, resume)");
        return false;
      }
      NODELET_ERROR("%s (save_dir): not journaled, a restart could not resume", e.what());
    }
    return true;
  }

  /// Writes a nodelet's files: returns the files it wrote, nullopt when it could not run, and
  /// throws on an error.
  using WriteFiles = std::function<std::optional<std::vector<std::string>>()>;
  /// Runs `write` when `service` (std_srvs/Trigger, private) is called, every save.period_s (of
  /// the clock rates follow; none when 0) and, with save.on_shutdown, at shutdown
  /// (saveAtShutdown). Each run logs what happened, which the service's reply also says.
  void serveSaving(const std::string& service, const ros_params::SaveSettings& save,
                   WriteFiles write);
  /// The save at shutdown serveSaving promised: call it from the derived nodelet's destructor,
  /// while what `write` uses still lives.
  void saveAtShutdown();
  /// A configuration error unless `ok()` holds within `seconds` after this call (something
  /// another nodelet must bring, and nodelets load in no order): logged as failConfiguration
  /// says, then the nodelet stops its work (stopWork).
  void requireWithin(double seconds, std::function<bool()> ok, std::string error);

  /// Subscribes `callback` to `topic` for the nodelet's lifetime, counting each message as the
  /// flow "in <topic>". The callback takes the message (const M&) or, to pass it on without a
  /// copy, its pointer (const M::ConstPtr&).
  template <class M, class F>
  void subscribe(const std::string& topic, int queue_size, F callback) {
    using Ptr = boost::shared_ptr<M const>;
    const boost::function<void(const Ptr&)> counted = [this, flow = "in " + topic,
                                                       callback](const Ptr& msg) {
      count(flow);
      if constexpr (std::is_invocable_v<F, const Ptr&>) {
        callback(msg);
      } else {
        callback(*msg);
      }
    };
    subscribers_.push_back(getNodeHandle().subscribe<M>(topic, queue_size, counted));
  }
  /// The same for a member function of the nodelet.
  template <class M, class N>
  void subscribe(const std::string& topic, int queue_size, void (N::*callback)(const M&)) {
    subscribe<M>(topic, queue_size, [self = static_cast<N*>(this), callback](const M& msg) {
      (self->*callback)(msg);
    });
  }
  template <class M, class N>
  void subscribe(const std::string& topic, int queue_size,
                 void (N::*callback)(const boost::shared_ptr<M const>&)) {
    subscribe<M>(topic, queue_size,
                 [self = static_cast<N*>(this), callback](const boost::shared_ptr<M const>& msg) {
                   (self->*callback)(msg);
                 });
  }

  /// Advertises `topic` for publish(); call in onInit only.
  template <class M>
  void advertise(const std::string& topic, int queue_size, bool latch = false) {
    publishers_[topic] = getNodeHandle().advertise<M>(topic, queue_size, latch);
  }
  /// Publishes on an advertised topic (zero-copy: never touch `msg` afterwards), counting it as
  /// the flow "out <topic>" with its serialised size.
  template <class M>
  void publish(const std::string& topic, const boost::shared_ptr<M>& msg) {
    count("out " + topic, ros::serialization::serializationLength(*msg));
    publishers_.at(topic).publish(msg);
  }
  /// Whether anyone listens on an advertised topic (outputs only worth making for a listener).
  bool listened(const std::string& topic) const {
    return publishers_.at(topic).getNumSubscribers() > 0;
  }

  /// Serves dynamic_reconfigure for the keys of `table`: a request is applied to a copy of
  /// `params`, validated by the core and logged key by key; `params` then takes it and `apply`
  /// hands it to the core stage. A refused request is logged and changes nothing.
  template <class Config, class Params, class Apply>
  void serveReconfigure(const ros_params::ReconfigureTable<Config, Params>& table, Params& params,
                        Apply apply) {
    auto server = std::make_shared<dynamic_reconfigure::Server<Config>>(reconfigure_mutex_,
                                                                        getPrivateNodeHandle());
    server->setCallback([this, &table, &params, apply](Config& config, uint32_t) {
      const auto outcome = table.apply(config, params);
      if (outcome.error) {
        NODELET_ERROR("reconfigure rejected: %s", outcome.error->c_str());
        return;
      }
      if (!outcome.changes.empty()) NODELET_INFO("reconfigured:%s", outcome.changes.c_str());
      params = outcome.params;
      apply(params);
    });
    reconfigure_server_ = std::move(server);
  }

  /// Logs a warning at most once per 5 s for each `kind` of problem: one throttle per call
  /// site would hide every kind but the first that passes through it.
  void warnPerKind(const std::string& kind, const char* format, ...)
      __attribute__((format(printf, 3, 4)));
  /// Counts a message dropped from `flow` ("dropped <flow>") and warns why, at most once per 5 s
  /// for each flow and format.
  void drop(const std::string& flow, const char* format, ...) __attribute__((format(printf, 3, 4)));

  /// Counts messages (and bytes) that passed through a named input or output.
  void count(const std::string& flow, std::uint64_t bytes = 0);
  /// Counts a message dropped from `flow` in its total ("dropped <flow>") and, when `kind` is
  /// set, per reason ("dropped <flow> (<kind>)").
  void countDropped(const std::string& flow, const std::string& kind) {
    count("dropped " + flow);
    if (!kind.empty()) count("dropped " + flow + " (" + kind + ")");
  }
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
  bool saveFiles(std::string* message);

  std::vector<ros::SteadyTimer> timers_;
  std::vector<ros::Subscriber> subscribers_;
  WriteFiles write_files_;  // serveSaving's
  bool save_at_shutdown_ = false;
  ros::ServiceServer save_service_;
  ros::SteadyTimer requirement_timer_;                // requireWithin's
  std::map<std::string, ros::Publisher> publishers_;  // by topic; written in onInit only
  boost::recursive_mutex reconfigure_mutex_;
  std::shared_ptr<void> reconfigure_server_;
  void warnVPerKind(const std::string& kind, const char* format, va_list args);

  std::mutex warned_mutex_;                           // guards last_warned_
  std::map<std::string, ros::WallTime> last_warned_;  // by kind
  std::vector<std::string> config_errors_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::SteadyTimer diagnostics_timer_;
};

}  // namespace ccir_mapping
