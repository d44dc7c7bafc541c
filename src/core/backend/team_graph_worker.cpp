#include "ccir_mapping/core/backend/team_graph_worker.h"

#include <future>

#include "ccir_mapping/core/backend/team_graph_journal.h"

namespace ccir_mapping::core::backend {

using pose_graph::LoopClosureData;

namespace {

std::string describe(const LoopClosureData& loop) {
  return "loop closure " + loop.robot_from + "/" + std::to_string(loop.keyframe_from) + " -> " +
         loop.robot_to + "/" + std::to_string(loop.keyframe_to);
}

}  // namespace

TeamGraphWorker::TeamGraphWorker(std::unique_ptr<TeamGraph> graph, Hooks hooks, Threading threading)
    : graph_robot_(graph->robot()), graph_(std::move(graph)), hooks_(std::move(hooks)) {
  if (threading == Threading::kOwnThread) thread_ = std::thread([this] { run(); });
}

TeamGraphWorker::~TeamGraphWorker() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void TeamGraphWorker::add(const OwnKeyframe& keyframe) {
  const std::string what = "keyframe " + std::to_string(keyframe.id) + " of '" + keyframe.robot;
  if (keyframe.robot != graph_robot_)
    return refuse(Refusal::kKeyframe, what + "': not this robot's");
  if (!keyframe.odom_pose || !isValidPose(*keyframe.odom_pose)) {
    return refuse(Refusal::kKeyframe, what + "': its pose is not finite");
  }
  queue(keyframe);
}

void TeamGraphWorker::add(const PeerKeyframe& keyframe) {
  const std::string what = "keyframe " + std::to_string(keyframe.id) + " of '" + keyframe.robot;
  if (keyframe.robot.empty() || keyframe.robot == graph_robot_) {
    return refuse(Refusal::kPeerKeyframe, what + "': not a teammate's");
  }
  if (!keyframe.pose || !isValidPose(*keyframe.pose)) {
    return refuse(Refusal::kPeerKeyframe, what + "': its pose is not finite");
  }
  queue(keyframe);
}
bool TeamGraphWorker::addOwnLoop(const LoopClosureData& loop) {
  if (const auto problem = pose_graph::loopClosureProblem(loop)) {
    refuse(Refusal::kLoopClosure, describe(loop) + ": " + *problem);
    return false;
  }
  switch (pose_graph::routeOwnLoop(graph_robot_, loop)) {
    case pose_graph::LoopRoute::kUseAndForward:
      queue(loop);
      return true;
    case pose_graph::LoopRoute::kUse:
      queue(loop);
      return false;
    default:
      refuse(Refusal::kLoopClosure, describe(loop) + ": it does not involve this robot");
      return false;
  }
}

void TeamGraphWorker::addTeammateLoop(const LoopClosureData& loop) {
  if (const auto problem = pose_graph::loopClosureProblem(loop)) {
    return refuse(Refusal::kTeammateLoopClosure, describe(loop) + ": " + *problem);
  }
  switch (pose_graph::routeTeammateLoop(graph_robot_, loop)) {
    case pose_graph::LoopRoute::kUse:
      queue(PeerKeyframe{loop.robot_from, loop.keyframe_from, *loop.odom_pose_from});
      if (loop.robot_to != graph_robot_ && loop.robot_to != loop.robot_from && loop.odom_pose_to) {
        queue(PeerKeyframe{loop.robot_to, loop.keyframe_to, *loop.odom_pose_to});
      }
      return queue(loop);
    case pose_graph::LoopRoute::kIgnore:
      return refuse(Refusal::kIgnoredLoopClosure, describe(loop) + ": this robot's own");
    default:
      refuse(
          Refusal::kTeammateLoopClosure,
          describe(loop) + (loop.odom_pose_from ? ": within one teammate" : ": no odom_pose_from"));
  }
}

TeamGraphWorker::RefusalReport TeamGraphWorker::reportOf(Refusal why) {
  switch (why) {
    case Refusal::kKeyframe:
      return {"keyframes", true};
    case Refusal::kPeerKeyframe:
      return {"teammate_scans", true};
    case Refusal::kLoopClosure:
      return {"loop_closures", true};
    case Refusal::kTeammateLoopClosure:
      return {"inbox/loop_closures", true};
    case Refusal::kIgnoredLoopClosure:
      return {"ignored inbox/loop_closures (this robot's own)", false};
    case Refusal::kDuplicateLoopClosure:
      break;
  }
  return {"duplicate loop_closures", false};  // the teammate found it too
}

void TeamGraphWorker::refuse(Refusal why, const std::string& text) const {
  if (hooks_.refused) hooks_.refused(why, text);
}

void TeamGraphWorker::tick() {
  if (!thread_.joinable()) {
    std::deque<Input> inputs;
    inputs.swap(inputs_);
    if (!inputs.empty() || resolve_) optimize(inputs);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    due_ = true;
  }
  wake_.notify_one();
}

bool TeamGraphWorker::inspect(const std::function<void(const TeamGraph&)>& task) {
  if (!thread_.joinable()) {
    task(*graph_);
    return true;
  }
  auto done = std::make_shared<std::promise<void>>();
  std::future<void> finished = done->get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_) return false;
    tasks_.push_back([task, done](const TeamGraph& graph) {
      try {
        task(graph);
        done->set_value();
      } catch (...) {
        done->set_exception(std::current_exception());
      }
    });
  }
  wake_.notify_one();
  try {
    finished.get();
  } catch (const std::future_error&) {
    return false;  // dropped by a stopping worker
  }
  return true;
}

std::size_t TeamGraphWorker::keepJournal(TeamGraphJournal& journal) {
  auto saved = journal.takeSaved();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& input : saved) inputs_.push_back(std::move(input));
    journal_ = &journal;
  }
  if (!saved.empty()) tick();
  return saved.size();
}

void TeamGraphWorker::queue(Input input) {
  // One lock: the journal keeps the inputs in the order the graph takes them.
  std::lock_guard<std::mutex> lock(mutex_);
  if (journal_) {
    try {
      journal_->append(input);
    } catch (const std::exception& e) {
      if (hooks_.unjournaled) hooks_.unjournaled(e.what());
    }
  }
  inputs_.push_back(std::move(input));
}

void TeamGraphWorker::run() {
  while (true) {
    std::deque<Input> inputs;
    std::deque<std::function<void(const TeamGraph&)>> tasks;
    bool due = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || due_ || !tasks_.empty(); });
      if (stop_) return;
      due = due_;
      if (due_) inputs.swap(inputs_);
      due_ = false;
      tasks.swap(tasks_);
    }
    if (!inputs.empty() || (due && resolve_)) optimize(inputs);
    for (const auto& task : tasks) task(*graph_);
  }
}

void TeamGraphWorker::optimize(const std::deque<Input>& inputs) {
  const BackendSnapshot snapshot = hooks_.run([&] {
    for (const Input& input : inputs) apply(input);
    return graph_->optimize();
  });
  resolve_ = snapshot.cut_short;
  if (hooks_.optimized) hooks_.optimized(snapshot, *graph_);
}

void TeamGraphWorker::apply(const Input& input) {
  if (const auto* own = std::get_if<OwnKeyframe>(&input)) {
    if (!graph_->addKeyframe(own->id, own->stamp, *own->odom_pose)) {
      refuse(Refusal::kKeyframe, "keyframe " + std::to_string(own->id) + ": ids must increase");
    }
  } else if (const auto* peer = std::get_if<PeerKeyframe>(&input)) {
    if (!graph_->addPeerKeyframe(peer->robot, peer->id, *peer->pose)) {
      refuse(Refusal::kPeerKeyframe, "keyframe " + std::to_string(peer->id) + " of '" +
                                         peer->robot + "': rejected by the graph");
    }
  } else {
    const auto& loop = std::get<LoopClosureData>(input);
    if (graph_->knows(loop)) {
      refuse(Refusal::kDuplicateLoopClosure, describe(loop) + ": known");
    } else if (!graph_->addLoopClosure(loop)) {
      refuse(Refusal::kLoopClosure, describe(loop) + ": rejected by the graph");
    }
  }
}

}  // namespace ccir_mapping::core::backend
