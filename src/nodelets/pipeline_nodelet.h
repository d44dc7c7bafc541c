// Base of every ccir_mapping nodelet: typed configuration that fails fast, per-topic flow
// counters, and diagnostics that show both.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

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

  /// Appends " name before -> after" to `changes` when a reconfigured value changed.
  template <class T>
  static void noteChange(std::ostream& changes, const char* name, const T& before, const T& after) {
    if (before != after) changes << " " << name << " " << before << " -> " << after;
  }

  /// A configuration error found after loadSettings (e.g. a file a parameter names): logs it as
  /// FATAL and reports it on diagnostics like an invalid parameter. The caller stays inert.
  void failConfiguration(const std::string& error);

  /// Counts messages (and bytes) that passed through a named input or output.
  void count(const std::string& flow, std::uint64_t bytes = 0);
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
  std::mutex status_mutex_;
  std::map<std::string, Flow> flows_;
  std::vector<std::string> config_errors_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::SteadyTimer diagnostics_timer_;
};

}  // namespace ccir_mapping
