// A whole team in simulated time, without ROS: each robot's keyframes from a simulated mission
// (KeyframeFeed), its stages as its nodelets chain them (RobotPipeline), and the links between
// robots through the Bridge's scheduler and token buckets over an emulated radio (TeamLink).
//
// Mission time advances in steps. In a step every robot handles, in time order, its keyframes
// and the messages that reached it before the step began, and runs its periodic work; then
// every robot's outbox goes onto its links, whose frames leave as the buckets allow during the
// step. Robots touch only their own state in the first half and only their own links in the
// second, so both halves run on `threads` threads and a run is the same for any thread count,
// determined by its parameters and seed alone.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/team_graph.h"
#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "ccir_mapping/core/routing/routing_messages.h"
#include "ccir_mapping/core/runner/runner_params.h"
#include "ccir_mapping/core/transport/link_scheduler.h"

namespace ccir_mapping::core::runner {

/// One robot's estimate of a teammate's frame at a time, against the truth.
struct TransformSample {
  double t_s = 0.0;
  bool valid = false;
  int inliers = 0;
  double error_m = 0.0;
  double error_deg = 0.0;
};

struct RobotResult {
  std::string name;
  std::size_t keyframes = 0;
  /// CPU seconds of its pipeline (matching, back end, map, routing), and of
  /// its simulated recording with the Preprocessor's stage; the pipeline's by stage.
  double pipeline_cpu_s = 0.0;
  double recording_cpu_s = 0.0;
  std::map<std::string, double> stage_cpu_s;
  std::uint64_t dropped_scans = 0;
  /// RMS position error of its keyframes: optimised, and as odometry put them.
  double ate_m = 0.0;
  double odometry_ate_m = 0.0;
  int own_loops = 0;
  int inter_robot_loops = 0;
  information::MapperStage::Stats map;
  routing::BrokerReport broker;
  std::map<std::string, std::uint64_t> refusals;
  /// Per teammate: what its link to it carried, the first time a transform to it was valid
  /// and the last one's error.
  std::map<std::string, transport::LinkCounters> links;
  std::vector<backend::TeamEstimate> team;
  std::map<std::string, TransformSample> transforms;

  // Time series, one row per series_period_s (mission seconds since the mission's start).
  std::map<std::string, std::vector<std::pair<double, std::uint64_t>>> bytes_series;
  /// t, known volume m^3, entropy bits.
  std::vector<std::array<double, 3>> map_series;
  /// t, CPU seconds so far (pipeline and recording).
  std::vector<std::pair<double, double>> cpu_series;
  std::map<std::string, std::vector<TransformSample>> transform_series;
  /// What the pipeline has done so far, one row per series period.
  struct Work {
    double t = 0.0;
    std::size_t keyframes = 0;
    std::size_t places = 0;
    std::uint64_t verifications = 0;
    std::map<std::string, double> stage_cpu_s;
  };
  std::vector<Work> work_series;
  /// t, mission seconds a loop closure found then waited for the verification budget.
  std::vector<std::pair<double, double>> closure_waits;
};

struct TeamResult {
  double duration_s = 0.0;
  double wall_s = 0.0;
  /// CPU seconds of the whole run (every thread).
  double cpu_s = 0.0;
  std::vector<RobotResult> robots;
  /// t, resident memory of the process (bytes), one row per series period.
  std::vector<std::pair<double, std::uint64_t>> memory_series;
  /// Mission seconds each link was up, by "a->b" (links never up are absent).
  std::map<std::string, double> link_up_s;
};

class TeamRunner {
 public:
  /// Progress: mission seconds done of the total, and the run's wall seconds so far.
  using Progress = std::function<void(double done_s, double total_s, double wall_s)>;

  /// Throws std::invalid_argument naming the first invalid parameter.
  TeamRunner(const RunnerParams& params, std::shared_ptr<const place_recognition::PlaceModel> model,
             int threads = 1);

  /// Runs the mission to its end. Throws std::runtime_error when a robot's recording fails.
  TeamResult run(const Progress& progress = {});

 private:
  RunnerParams params_;
  std::shared_ptr<const place_recognition::PlaceModel> model_;
  int threads_;
};

}  // namespace ccir_mapping::core::runner
