// One robot of a team run: the stages its nodelets wrap (MatcherStage, BackendStage on the
// caller's thread, MapperStage, BrokerStage), chained as the topics of launch/robot.launch chain
// them, with the messages to teammates collected in an outbox. Every decision is the stages';
// this only routes what each returns. Each call runs to the end before it returns, so a run
// depends only on the order of the calls (core/runner/team_runner.h makes that order).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/backend_stage.h"
#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/place_recognition/matcher_stage.h"
#include "ccir_mapping/core/routing/broker_stage.h"
#include "ccir_mapping/core/runner/keyframe_feed.h"
#include "ccir_mapping/core/runner/runner_params.h"
#include "ccir_mapping/core/runner/team_message.h"

namespace ccir_mapping::core::runner {

class RobotPipeline {
 public:
  /// A message for one teammate, or ("") for every teammate linked at the time.
  struct Outgoing {
    double time_s = 0.0;
    std::string peer;
    TeamMessage message;
  };

  /// Its periodic work is first due at `start_s` plus `phase` (in [0, 1)) of each period: the
  /// timers of robots on separate masters do not tick together. Throws std::invalid_argument
  /// when a stage's parameters are invalid.
  RobotPipeline(std::string name, std::vector<std::string> peers, const RunnerParams& params,
                std::shared_ptr<const place_recognition::PlaceModel> model, double start_s = 0.0,
                double phase = 0.0);

  const std::string& name() const { return name_; }

  /// An own keyframe, at mission second `now_s`.
  void onKeyframe(double now_s, const SimKeyframe& keyframe);
  /// A teammate's message, as the inbox delivers it.
  void onMessage(double now_s, const TeamMessage& message);
  /// The periodic work due by `now_s`: the Broker's offer period, the Backend's optimisation,
  /// the Mapper's following of moved poses.
  void runTimers(double now_s);
  /// LinkStats of the link to `peer`.
  void setLink(const std::string& peer, const routing::LinkState& state);

  /// What was sent since the last call, in order.
  std::vector<Outgoing> takeOutbox();

  /// The newest optimisation (empty before the first).
  const backend::BackendSnapshot& snapshot() const { return snapshot_; }
  information::MapperStage::Stats mapStats() const { return map_.stats(); }
  routing::BrokerReport brokerReport() const { return broker_.ccir().report(); }
  /// Loop closures this robot verified (own, with teammates), and refusals by kind.
  int ownLoops() const { return own_loops_; }
  int interRobotLoops() const { return inter_loops_; }
  const std::map<std::string, std::uint64_t>& refusals() const { return refusals_; }
  /// Places the Matcher holds (own keyframes and kept teammates' scans) and candidates it verified.
  std::size_t places() const {
    return matcher_.matcher().places() + matcher_.matcher().keptScans();
  }
  std::uint64_t verifications() const { return verifications_; }
  /// Mission time of each loop closure found, with what it waited for the verification budget.
  const std::vector<std::pair<double, double>>& closureWaits() const { return closure_waits_; }
  /// CPU seconds by stage, as the nodelets report them on diagnostics ("describe", "match",
  /// "insert", "reanchor", "optimise", "footprint", "route", "codec").
  std::map<std::string, double> stageCpu() const;

 private:
  using Broker = routing::BrokerStage<std::shared_ptr<const routing::WireScan>>;
  struct Timer {
    double period_s;
    double next_s;
    bool due(double now_s);
  };

  void send(double now_s, std::string peer, TeamMessage message);
  /// What the Matcher's step returned, as its topics carry it: word sets to the teammates, c_k
  /// to the Broker, loop closures to the Backend (and on to the teammates when it says so).
  void route(double now_s, const place_recognition::MatcherStage::Output& out);
  /// What the Broker's step returned, to the teammates.
  void route(double now_s, const Broker::Output& out);
  /// An optimisation, to the Broker and the Mapper.
  void route(const backend::BackendStage::Output& out);
  void onScan(double now_s, const routing::WireScan& scan);
  void refuse(const std::string& kind) { ++refusals_[kind]; }
  /// Runs `work`, adding its thread's CPU seconds to `stage`.
  template <class F>
  decltype(auto) measured(const char* stage, F&& work);
  /// The stages' Hooks::run: each piece of their work measured.
  std::function<void(const char* stage, const std::function<void()>& work)> meter();
  void addCpu(const char* stage, double seconds);

  const std::string name_;
  mutable std::mutex cpu_mutex_;  // a stage's hooks may measure on a thread of its own
  std::map<std::string, double> stage_cpu_;
  place_recognition::MatcherStage matcher_;
  information::MapperStage map_;
  Broker broker_;
  std::unique_ptr<backend::BackendStage> backend_;  // last: its hooks use the stages above
  Timer offers_, optimisation_, map_update_;
  backend::BackendSnapshot snapshot_;
  std::vector<Outgoing> outbox_;
  int own_loops_ = 0, inter_loops_ = 0;
  std::uint64_t verifications_ = 0;
  std::vector<std::pair<double, double>> closure_waits_;
  std::map<std::string, std::uint64_t> refusals_;
};

}  // namespace ccir_mapping::core::runner
