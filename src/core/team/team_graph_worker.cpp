#include "ccir_mapping/core/team/team_graph_worker.h"

namespace ccir_mapping::core::team {

using backend::LoopClosureData;

namespace {

std::string describe(const LoopClosureData& loop) {
  return "loop closure " + loop.robot_from + "/" + std::to_string(loop.keyframe_from) + " -> " +
         loop.robot_to + "/" + std::to_string(loop.keyframe_to);
}

}  // namespace

TeamGraphWorker::TeamGraphWorker(std::unique_ptr<TeamGraph> graph, Hooks hooks)
    : graph_(std::move(graph)), hooks_(std::move(hooks)), thread_([this] { run(); }) {}

TeamGraphWorker::~TeamGraphWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void TeamGraphWorker::add(OwnKeyframe keyframe) { queue(std::move(keyframe), false); }
void TeamGraphWorker::add(PeerKeyframe keyframe) { queue(std::move(keyframe), false); }
void TeamGraphWorker::add(LoopClosureData loop) { queue(std::move(loop), true); }

void TeamGraphWorker::tick() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    due_ = true;
  }
  wake_.notify_one();
}

void TeamGraphWorker::queue(Input input, bool urgent) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    inputs_.push_back(std::move(input));
    due_ = due_ || urgent;
  }
  if (urgent) wake_.notify_one();
}

void TeamGraphWorker::run() {
  while (true) {
    std::deque<Input> inputs;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || due_; });
      if (stop_) return;
      due_ = false;
      inputs.swap(inputs_);
    }
    if (inputs.empty()) continue;
    const BackendSnapshot snapshot = hooks_.run([&] {
      for (const Input& input : inputs) apply(input);
      return graph_->optimize();
    });
    if (hooks_.optimized) hooks_.optimized(snapshot, *graph_);
  }
}

void TeamGraphWorker::apply(const Input& input) {
  const auto refuse = [this](Refusal why, const std::string& what) {
    if (hooks_.refused) hooks_.refused(why, what);
  };
  if (const auto* own = std::get_if<OwnKeyframe>(&input)) {
    if (!graph_->addKeyframe(own->id, own->stamp, own->odom_pose)) {
      refuse(Refusal::kKeyframe, "keyframe " + std::to_string(own->id));
    }
  } else if (const auto* peer = std::get_if<PeerKeyframe>(&input)) {
    if (!graph_->addPeerKeyframe(peer->robot, peer->id, peer->pose)) {
      refuse(Refusal::kPeerKeyframe, "keyframe " + peer->robot + "/" + std::to_string(peer->id));
    }
  } else {
    const auto& loop = std::get<LoopClosureData>(input);
    if (graph_->knows(loop)) {
      refuse(Refusal::kDuplicateLoopClosure, describe(loop));
    } else if (!graph_->addLoopClosure(loop)) {
      refuse(Refusal::kLoopClosure, describe(loop));
    }
  }
}

}  // namespace ccir_mapping::core::team
