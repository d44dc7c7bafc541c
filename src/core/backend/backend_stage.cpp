#include "ccir_mapping/core/backend/backend_stage.h"

namespace ccir_mapping::core::backend {

BackendStage::BackendStage(const std::string& robot, const BackendParams& params, Hooks hooks,
                           Threading threading)
    : params_(params), robot_(robot), hooks_(std::move(hooks)) {
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
    latest_.solve_s = snapshot.solve_s;
    latest_.loops = snapshot.loops;
    latest_.windowed_solves += snapshot.solved == BackendSnapshot::Solve::kWindow;
    if (snapshot.solved == BackendSnapshot::Solve::kFull) {
      ++latest_.full_solves;
      latest_.full_correction_m = snapshot.full_correction_m;
    }
  }
  if (!hooks_.optimized) return;
  Output out{snapshot, std::nullopt};
  if (!snapshot.ids.empty() && hooks_.wants_uncertainty()) {
    out.uncertainty = uncertainty(snapshot, graph);
  }
  hooks_.optimized(out);
}

std::optional<std::vector<double>> BackendStage::uncertainty(const BackendSnapshot& snapshot,
                                                             const TeamGraph& graph) {
  const Stamp now = snapshot.stamps.back();
  if (!variances_stamp_ || now - *variances_stamp_ >= fromSeconds(params_.uncertainty_period_s)) {
    std::optional<std::vector<double>> computed;
    hooks_.run("uncertainty", [&] { computed = graph.positionVariances(snapshot.ids); });
    if (!computed) return std::nullopt;
    variances_.clear();
    for (std::size_t i = 0; i < snapshot.ids.size(); ++i) {
      variances_[snapshot.ids[i]] = (*computed)[i];
    }
    variances_stamp_ = now;
    return computed;
  }
  // Keyframes since: the newest marginal plus each odometry step's position variance, as the
  // odometry edges weigh it (isotropic: the geometric mean of its eigenvalues is its diagonal),
  // as TeamGraph::positionVariances carries it between its marginals.
  std::vector<double> variances(snapshot.ids.size(), 0.0);
  double carried = 0.0;
  for (std::size_t i = 0; i < snapshot.ids.size(); ++i) {
    const auto known = variances_.find(snapshot.ids[i]);
    if (known != variances_.end()) {
      carried = variances[i] = known->second;
    } else if (i > 0) {
      const Pose3 step = snapshot.poses[i - 1].inverse() * snapshot.poses[i];
      carried = variances[i] = carried + pose_graph::stepCovariance(step, params_.odometry)(0, 0);
    }
  }
  return variances;
}

}  // namespace ccir_mapping::core::backend
