// The Backend's stage: the team graph on its worker (TeamGraphWorker) with the journal a
// restarted robot resumes it from, in the shape every stage has. Inputs go in as plain data;
// each optimisation comes out as an Output (the snapshot, and the pose uncertainty u_k the
// Broker weighs, when the caller wants it); a refused input comes out as a Refusal. The Backend
// nodelet and the team runner (core/runner) both run it, so that neither decides anything of
// its own.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/team_graph_journal.h"
#include "ccir_mapping/core/backend/team_graph_worker.h"
#include "ccir_mapping/core/common/notice.h"

namespace ccir_mapping::core::backend {

class BackendStage {
 public:
  using OwnKeyframe = TeamGraphWorker::OwnKeyframe;
  using PeerKeyframe = TeamGraphWorker::PeerKeyframe;
  using Threading = TeamGraphWorker::Threading;

  struct Output {
    BackendSnapshot snapshot;
    /// u_k: the position variance of each of snapshot.ids (m^2), when Hooks::wants_uncertainty
    /// said so and the marginals could be computed.
    std::optional<std::vector<double>> uncertainty;
  };
  /// An input not taken: `notice.kind` is the flow (topic) it counts in; `dropped` says whether
  /// it was dropped (worth a warning) or only set aside (nothing wrong with it).
  struct Refusal {
    Notice notice;
    bool dropped = true;
  };
  struct Hooks {
    /// Runs a piece of work ("optimise", "uncertainty") and lets the caller measure it.
    std::function<void(const char* stage, const std::function<void()>& work)> run =
        [](const char*, const std::function<void()>& work) { work(); };
    /// After each optimisation, on the worker's thread (the caller's with Threading::kCaller).
    std::function<void(const Output&)> optimized;
    /// On the caller's thread or the worker's.
    std::function<void(const Refusal&)> refused;
    /// An input the journal could not keep, and why; on the caller's thread.
    std::function<void(const std::string&)> unjournaled;
    /// Whether the next Output carries the uncertainty (the marginals cost the most).
    std::function<bool()> wants_uncertainty = [] { return true; };
  };

  /// Throws std::invalid_argument when params.validate() reports errors.
  BackendStage(const std::string& robot, const BackendParams& params, Hooks hooks,
               Threading threading = Threading::kOwnThread);
  /// Stops the worker (inputs not applied yet are dropped), then closes the journal.
  ~BackendStage();

  /// Opens the journal of every input in DIR (TeamGraphJournal; with `resume`, reading what a
  /// previous run journaled there). Throws std::runtime_error naming the file it cannot use.
  void openJournal(const std::string& dir, bool resume);
  /// Journals every input from now on, after optimising what the journal resumed; returns how
  /// many inputs that was. Call before any input (the Output it may produce at once must have
  /// somewhere to go).
  std::size_t keepJournal();

  void add(const OwnKeyframe& keyframe) { worker_->add(keyframe); }
  void add(const PeerKeyframe& keyframe) { worker_->add(keyframe); }
  /// A closure this robot's Matcher found; true when it goes to the teammates too.
  bool addOwnLoop(const pose_graph::LoopClosureData& loop) { return worker_->addOwnLoop(loop); }
  /// A closure a teammate found and sent.
  void addTeammateLoop(const pose_graph::LoopClosureData& loop) { worker_->addTeammateLoop(loop); }
  /// Optimises if anything arrived since the last optimisation.
  void tick() { worker_->tick(); }
  /// The newest optimisation's figures, for diagnostics (from any thread).
  struct Latest {
    double solve_s = 0.0;
    BackendSnapshot::LoopCounts loops;
    /// Solves so far, and how far the newest full solve moved the farthest pose from where the
    /// windowed ones had left it (BackendSnapshot::full_correction_m).
    int windowed_solves = 0, full_solves = 0;
    double full_correction_m = 0.0;
  };
  Latest latest() const;
  /// Writes the graph's files (TeamGraph::save) to DIR once the optimisation under way is done;
  /// nullopt when the worker stopped first. Throws std::runtime_error naming what it could not
  /// write.
  std::optional<std::vector<std::string>> save(const std::string& dir);

 private:
  void optimized(const BackendSnapshot& snapshot, const TeamGraph& graph);
  /// u_k of snapshot.ids: the marginals when uncertainty_period_s has passed since the last
  /// ones (mission time), else those kept, newer keyframes extended by odometry drift.
  std::optional<std::vector<double>> uncertainty(const BackendSnapshot& snapshot,
                                                 const TeamGraph& graph);

  const BackendParams params_;
  std::map<KeyframeId, double> variances_;  // the last marginals (the worker's thread)
  std::optional<Stamp> variances_stamp_;

  const std::string robot_;
  Hooks hooks_;
  mutable std::mutex latest_mutex_;
  Latest latest_;
  std::optional<TeamGraphJournal> journal_;  // outlives the worker that writes it
  std::unique_ptr<TeamGraphWorker> worker_;
};

}  // namespace ccir_mapping::core::backend
