// A TeamGraph on a thread of its own: callers hand over keyframes and loop closures and return
// at once; the worker applies them and re-optimises at each tick() and as soon as a loop
// closure arrives, so a solve never holds the caller's thread (a nodelet manager's).
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <variant>

#include "ccir_mapping/core/team/team_graph.h"

namespace ccir_mapping::core::team {

class TeamGraphWorker {
 public:
  struct OwnKeyframe {
    KeyframeId id = 0;
    Stamp stamp = 0;
    Pose3 odom_pose = Pose3::Identity();
  };
  struct PeerKeyframe {
    std::string robot;
    KeyframeId id = 0;
    Pose3 pose = Pose3::Identity();
  };
  /// What the graph did not take.
  enum class Refusal {
    kKeyframe,              ///< an own keyframe whose id does not increase, or invalid
    kPeerKeyframe,          ///< a teammate's keyframe the graph rejected
    kLoopClosure,           ///< a loop closure the graph rejected (e.g. a keyframe to itself)
    kDuplicateLoopClosure,  ///< one it has (the teammate found and sent it too)
  };
  struct Hooks {
    /// Runs a batch (apply the inputs, optimise) and returns its snapshot: lets the caller
    /// measure it.
    std::function<BackendSnapshot(const std::function<BackendSnapshot()>&)> run =
        [](const std::function<BackendSnapshot()>& batch) { return batch(); };
    /// After each optimisation, on the worker's thread; the graph may be asked more (e.g.
    /// positionVariances) until it returns.
    std::function<void(const BackendSnapshot&, const TeamGraph&)> optimized;
    /// A refused input, with what it was ("keyframe 12", "loop closure a/3 -> b/7").
    std::function<void(Refusal, const std::string&)> refused;
  };

  TeamGraphWorker(std::unique_ptr<TeamGraph> graph, Hooks hooks);
  /// Stops the worker; inputs not applied yet are dropped.
  ~TeamGraphWorker();

  void add(OwnKeyframe keyframe);
  void add(PeerKeyframe keyframe);
  /// Optimises as soon as the worker is free.
  void add(backend::LoopClosureData loop);
  /// Optimises if anything arrived since the last optimisation.
  void tick();

 private:
  using Input = std::variant<OwnKeyframe, PeerKeyframe, backend::LoopClosureData>;
  void queue(Input input, bool urgent);
  void run();
  void apply(const Input& input);

  std::unique_ptr<TeamGraph> graph_;  // the worker's
  Hooks hooks_;
  std::mutex mutex_;  // guards what callers hand to the worker
  std::condition_variable wake_;
  std::deque<Input> inputs_;
  bool due_ = false;
  bool stop_ = false;
  std::thread thread_;  // last: starts once everything above is constructed
};

}  // namespace ccir_mapping::core::team
