// A TeamGraph on a thread of its own: callers hand over keyframes and loop closures and return
// at once; the worker applies them at each tick() and optimises (TeamGraph::optimize decides
// what to solve), so a solve never holds the caller's thread (a nodelet manager's) and happens
// at most once a tick. On the caller's thread instead (Threading::kCaller) tick() returns with
// the optimisation done, so a program in simulated time (core/runner) gets the same
// optimisations in the same order on every run.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "ccir_mapping/core/backend/team_graph.h"

namespace ccir_mapping::core::backend {

class TeamGraphJournal;

class TeamGraphWorker {
 public:
  /// This robot's keyframe with its odometry pose (unset when its message had no valid one).
  struct OwnKeyframe {
    std::string robot;
    KeyframeId id = 0;
    Stamp stamp = 0;
    std::optional<Pose3> odom_pose;
  };
  /// A teammate's keyframe with its pose in the teammate's frame (unset: none valid).
  struct PeerKeyframe {
    std::string robot;
    KeyframeId id = 0;
    std::optional<Pose3> pose;
  };
  /// What the graph, or the rules before it (core/pose_graph/loop_closure.h), did not take.
  enum class Refusal {
    kKeyframe,      ///< not this robot's, without a valid pose, or an id that does not increase
    kPeerKeyframe,  ///< not a teammate's, without a valid pose, or rejected by the graph
    /// A closure this robot found: unusable, not with this robot, or rejected by the graph.
    kLoopClosure,
    /// A closure a teammate sent: unusable, without its keyframe's odometry pose, or within it.
    kTeammateLoopClosure,
    kIgnoredLoopClosure,    ///< this robot's own closure coming back from a teammate
    kDuplicateLoopClosure,  ///< one it has (the teammate found and sent it too)
  };
  /// How a refusal shows in diagnostics: the flow (topic) it counts in, and whether the input
  /// was dropped (worth a warning) or only set aside (nothing wrong with it).
  struct RefusalReport {
    const char* flow;
    bool dropped;
  };
  static RefusalReport reportOf(Refusal why);

  struct Hooks {
    /// Runs a batch (apply the inputs, optimise) and returns its snapshot: lets the caller
    /// measure it.
    std::function<BackendSnapshot(const std::function<BackendSnapshot()>&)> run =
        [](const std::function<BackendSnapshot()>& batch) { return batch(); };
    /// After each optimisation, on the worker's thread; the graph may be asked more (e.g.
    /// positionVariances) until it returns.
    std::function<void(const BackendSnapshot&, const TeamGraph&)> optimized;
    /// A refused input, saying what it was and why ("keyframe 12: ids must increase"); on the
    /// caller's thread or the worker's.
    std::function<void(Refusal, const std::string&)> refused;
    /// An input the journal (keepJournal) could not keep, and why; on the caller's thread.
    std::function<void(const std::string&)> unjournaled;
  };

  /// What it hands the graph, routed and checked.
  using Input = std::variant<OwnKeyframe, PeerKeyframe, pose_graph::LoopClosureData>;

  enum class Threading { kOwnThread, kCaller };

  TeamGraphWorker(std::unique_ptr<TeamGraph> graph, Hooks hooks,
                  Threading threading = Threading::kOwnThread);
  /// Stops the worker; inputs not applied yet are dropped.
  ~TeamGraphWorker();

  void add(const OwnKeyframe& keyframe);
  void add(const PeerKeyframe& keyframe);
  /// A closure this robot's Matcher found, solved at the next tick; true when it goes to the
  /// teammates too (pose_graph::routeOwnLoop).
  bool addOwnLoop(const pose_graph::LoopClosureData& loop);
  /// A closure a teammate found, with its keyframe and that keyframe's odometry pose
  /// (pose_graph::routeTeammateLoop).
  void addTeammateLoop(const pose_graph::LoopClosureData& loop);
  /// Resumes what `journal` (which outlives the worker) saved of a previous run: its inputs
  /// are applied in their order and optimised at once (closures are not routed to teammates
  /// again). From then on each input taken is appended to it before it is applied. Returns the
  /// number of inputs resumed; call it before any input.
  std::size_t keepJournal(TeamGraphJournal& journal);
  /// Optimises if anything arrived since the last optimisation.
  void tick();
  /// Runs `task` with the graph on the worker's thread (after the optimisation under way, if
  /// any) and waits for it; rethrows what the task threw. False when the worker stopped first.
  /// Never from the worker's own thread (its hooks): it would wait for itself.
  bool inspect(const std::function<void(const TeamGraph&)>& task);

 private:
  void queue(Input input);
  void run();
  /// Applies `inputs`, optimises and reports (hooks.run, hooks.optimized).
  void optimize(const std::deque<Input>& inputs);
  void apply(const Input& input);
  void refuse(Refusal why, const std::string& text) const;

  const std::string graph_robot_;     // whose graph it is
  std::unique_ptr<TeamGraph> graph_;  // the worker's
  Hooks hooks_;
  std::mutex mutex_;  // guards what callers hand to the worker
  std::condition_variable wake_;
  std::deque<Input> inputs_;
  TeamGraphJournal* journal_ = nullptr;
  std::deque<std::function<void(const TeamGraph&)>> tasks_;  // inspect()'s
  bool due_ = false;
  /// The last optimisation was cut short by its time bound: the next tick optimises again,
  /// new inputs or not, so that a busy machine delays the optimum instead of losing it.
  bool resolve_ = false;  // the optimising thread's
  bool stop_ = false;
  std::thread thread_;  // last: starts once everything above is constructed (kOwnThread only)
};

}  // namespace ccir_mapping::core::backend
