#include "ccir_mapping/core/backend/backend_stage.h"

namespace ccir_mapping::core::backend {

BackendStage::BackendStage(const std::string& robot, const BackendParams& params, Hooks hooks,
                           Threading threading)
    : robot_(robot), hooks_(std::move(hooks)) {
  TeamGraphWorker::Hooks worker;
  worker.run = [this](const std::function<BackendSnapshot()>& batch) {
    std::optional<BackendSnapshot> snapshot;
    hooks_.run("optimise", [&] { snapshot.emplace(batch()); });
    return std::move(*snapshot);
  };
  worker.optimized = [this](const BackendSnapshot& snapshot, const TeamGraph& graph) {
    optimized(snapshot, graph);
  };
  worker.refused = [this](TeamGraphWorker::Refusal why, const std::string& what) {
    if (!hooks_.refused) return;
    const auto report = TeamGraphWorker::reportOf(why);
    hooks_.refused(
        {{report.flow, "dropping " + what + " (from " + report.flow + ")"}, report.dropped});
  };
  worker.unjournaled = hooks_.unjournaled;
  worker_ = std::make_unique<TeamGraphWorker>(std::make_unique<TeamGraph>(robot, params),
                                              std::move(worker), threading);
}

BackendStage::~BackendStage() { worker_.reset(); }

void BackendStage::openJournal(const std::string& dir, bool resume) {
  journal_.emplace(dir, robot_, resume);
}

std::size_t BackendStage::keepJournal() { return journal_ ? worker_->keepJournal(*journal_) : 0; }

std::optional<std::vector<std::string>> BackendStage::save(const std::string& dir) {
  std::vector<std::string> files;
  if (!worker_->inspect([&](const TeamGraph& graph) { files = graph.save(dir); })) {
    return std::nullopt;
  }
  return files;
}

BackendStage::Latest BackendStage::latest() const {
  std::lock_guard<std::mutex> lock(latest_mutex_);
  return latest_;
}

void BackendStage::optimized(const BackendSnapshot& snapshot, const TeamGraph& graph) {
  {
    std::lock_guard<std::mutex> lock(latest_mutex_);
    latest_ = {snapshot.solve_s, snapshot.loops};
  }
  if (!hooks_.optimized) return;
  Output out{snapshot, std::nullopt};
  if (!snapshot.ids.empty() && hooks_.wants_uncertainty()) {
    hooks_.run("uncertainty", [&] { out.uncertainty = graph.positionVariances(snapshot.ids); });
  }
  hooks_.optimized(out);
}

}  // namespace ccir_mapping::core::backend
