#include "pipeline_nodelet.h"

#include <cstdio>
#include <sstream>

namespace ccir_mapping {

PipelineNodelet::~PipelineNodelet() {
  std::lock_guard<std::mutex> lock(status_mutex_);
  if (flows_.empty()) return;
  std::ostringstream summary;
  for (const auto& [name, flow] : flows_) summary << " " << name << "=" << flow.messages;
  NODELET_INFO("flow at shutdown:%s", summary.str().c_str());
}

XmlRpc::XmlRpcValue PipelineNodelet::privateParams() {
  XmlRpc::XmlRpcValue values;
  // Absent namespace = no parameters set: every default applies.
  if (!ros::param::get(getPrivateNodeHandle().getNamespace(), values)) return {};
  return values;
}

bool PipelineNodelet::reportSettings(const ros_params::ParamReader& reader,
                                     const std::string& robot_name) {
  for (const std::string& key : reader.unknownKeys()) {
    NODELET_WARN("unknown parameter %s/%s is ignored (a typo?)", reader.ns().c_str(), key.c_str());
  }
  config_errors_ = reader.errors();
  for (const std::string& error : config_errors_) {
    NODELET_FATAL("invalid parameter in %s: %s; this nodelet stays inert", reader.ns().c_str(),
                  error.c_str());
  }
  if (config_errors_.empty()) NODELET_INFO("parameters: %s", reader.summary().c_str());

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(getNodeHandle(),
                                                               getPrivateNodeHandle(), getName());
  diagnostics_->setHardwareID(robot_name);
  diagnostics_->add("flow", this, &PipelineNodelet::produceDiagnostics);
  diagnostics_timer_ = getNodeHandle().createSteadyTimer(
      ros::WallDuration(1.0),
      [this](const ros::SteadyTimerEvent&) { diagnostics_->force_update(); });
  return config_errors_.empty();
}

void PipelineNodelet::failConfiguration(const std::string& error) {
  NODELET_FATAL("%s; this nodelet stays inert", error.c_str());
  std::lock_guard<std::mutex> lock(status_mutex_);
  config_errors_.push_back(error);
}

void PipelineNodelet::serveSaving(const std::string& service, const ros_params::SaveSettings& save,
                                  WriteFiles write) {
  write_files_ = std::move(write);
  save_at_shutdown_ = save.on_shutdown;
  save_service_ =
      getPrivateNodeHandle()
          .advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
              service, [this](std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
                response.success = saveFiles(&response.message);
                return true;
              });
  if (save.period_s > 0) {
    createPeriodicTimer(save.period_s, [this] {
      std::string message;
      saveFiles(&message);
    });
  }
}

void PipelineNodelet::saveAtShutdown() {
  save_service_.shutdown();
  std::string message;
  if (write_files_ && save_at_shutdown_) saveFiles(&message);
}

void PipelineNodelet::requireWithin(double seconds, std::function<bool()> ok, std::string error) {
  requirement_timer_ = getNodeHandle().createSteadyTimer(
      ros::WallDuration(seconds),
      [this, ok = std::move(ok), error = std::move(error)](const ros::SteadyTimerEvent&) {
        if (ok()) return;
        stopWork();
        failConfiguration(error);
      },
      /*oneshot=*/true);
}

bool PipelineNodelet::saveFiles(std::string* message) {
  try {
    const auto files = write_files_();
    if (!files) {
      *message = "stopping: not saved";
      NODELET_WARN("%s", message->c_str());
      return false;
    }
    *message = "saved";
    for (const std::string& file : *files) *message += " " + file;
    NODELET_INFO("%s", message->c_str());
    return true;
  } catch (const std::exception& e) {
    *message = std::string(e.what()) + " (~save_dir)";
    NODELET_ERROR("%s", message->c_str());
    return false;
  }
}

void PipelineNodelet::warnPerKind(const std::string& kind, const char* format, ...) {
  va_list args;
  va_start(args, format);
  warnVPerKind(kind, format, args);
  va_end(args);
}

void PipelineNodelet::drop(const std::string& flow, const char* format, ...) {
  count("dropped " + flow);
  va_list args;
  va_start(args, format);
  warnVPerKind(flow + "\n" + format, format, args);
  va_end(args);
}

void PipelineNodelet::warnVPerKind(const std::string& kind, const char* format, va_list args) {
  const ros::WallTime now = ros::WallTime::now();
  {
    std::lock_guard<std::mutex> lock(warned_mutex_);
    ros::WallTime& last = last_warned_[kind];
    if (!last.isZero() && (now - last).toSec() < 5.0) return;
    last = now;
  }
  char text[1024];
  std::vsnprintf(text, sizeof(text), format, args);
  NODELET_WARN("%s", text);
}

void PipelineNodelet::count(const std::string& flow, std::uint64_t bytes) {
  std::lock_guard<std::mutex> lock(status_mutex_);
  Flow& f = flows_[flow];
  ++f.messages;
  f.bytes += bytes;
}

void PipelineNodelet::addCpu(const std::string& stage, double seconds) {
  std::lock_guard<std::mutex> lock(status_mutex_);
  Cpu& c = cpu_[stage];
  ++c.runs;
  c.seconds += seconds;
}

void PipelineNodelet::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  {
    std::lock_guard<std::mutex> lock(status_mutex_);
    if (!config_errors_.empty()) {
      status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "inert: invalid parameters");
      for (std::size_t i = 0; i < config_errors_.size(); ++i) {
        status.add("error " + std::to_string(i), config_errors_[i]);
      }
      return;
    }
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "running");
    for (const auto& [name, flow] : flows_) {
      status.add(name + " messages", flow.messages);
      if (flow.bytes) status.add(name + " bytes", flow.bytes);
    }
    for (const auto& [stage, cpu] : cpu_) {
      status.addf("cpu s " + stage, "%.3f", cpu.seconds);
      status.add("cpu runs " + stage, cpu.runs);
    }
  }
  addDiagnostics(status);
}

}  // namespace ccir_mapping
