// Robust pose-graph optimisation on Ceres: odometry edges plain, loop closures as switchable
// constraints (Suenderhauf & Protzel) or with a robust loss, the first pose fixed.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/pose_graph/pose_graph.h"
#include "ccir_mapping/core/pose_graph/pose_graph_residuals.h"
#include "ccir_mapping/core/pose_graph/robust_kernel.h"

namespace ccir_mapping::core::pose_graph {

struct OptimizerParams {
  RobustKernel kernel = RobustKernel::kSwitchable;
  /// Linear psi(s) = s with s in [0, 1], prior 1 (default); sigmoid psi(s) = 1 / (1 + e^-s) with
  /// s in [-10, 10], prior 10.
  SwitchFunction switch_function = SwitchFunction::kLinear;
  /// Standard deviation of the switch prior. A linear switch settles at phi / (phi + chi^2)
  /// with phi = 1 / sigma^2, so 0 (auto) picks phi = the 99 % chi^2 quantile of the edge's
  /// dimension: a loop as likely as its covariance says stays on (1 rejects every loop with
  /// chi^2 > 1, including most true ones when informations are honest).
  double switch_prior_sigma = 0.0;
  /// DCS phi, in chi^2 units; 0 (auto) puts the scale's 0.5 crossing (chi^2 = 3 phi) at the
  /// 99 % quantile.
  double dcs_phi = 0.0;
  /// Scale of the Cauchy and Huber losses, on the whitened residual norm.
  double loss_scale = 1.0;
  int max_iterations = 200;
  /// When a solve turns most loops off, solve again starting from a solve with each loop's
  /// covariance inflated by the odometry uncertainty between its poses (true loops seen after
  /// long drift are then not switched off at the drifted guess) and keep the lower cost.
  bool uncertainty_aware_start = true;
  /// Finish with a plain solve over the loops kept as inliers (rejected ones left out).
  bool refine_inliers = true;
  /// Wall-time bound of one optimize() (all its solves together; Ceres stops at the bound).
  double max_solve_time_s = 600.0;
  int threads = 1;

  std::vector<std::string> validate() const;
};

struct OptimizationResult {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  double solve_s = 0.0;
  /// Ceres considers the solution usable (converged, or stopped by a limit at a valid point).
  bool usable = false;
  /// Per edge (index into graph.edges): the weight its residual ended with (psi(s), the DCS
  /// scale, or 1) and whether the loop is kept as an inlier. Odometry edges: 1 and true.
  std::vector<double> weights;
  std::vector<bool> inliers;
  /// Per edge: the switch variable it ended with (kSwitchable's loops; 1 for the others), to
  /// warm-start a later solve (SolveStart::switches).
  std::vector<double> switches;
  std::string summary;
};

/// Each edge's information, loops' with their covariance inflated by the odometry uncertainty
/// accumulated along the chain between their poses (propagated in the frame of the first, as
/// the residual is): at a drifted guess a true loop then looks as likely as it is (Dong et al.,
/// ICRA 2015, within one robot). Loops without an odometry chain keep their information.
std::vector<Information> chainInflatedInformation(const PoseGraph& graph);

/// The graph with its odometry chains thinned: the poses `keep` says and each chain's ends
/// stay, and the odometry steps between consecutive ones are composed into one edge (its
/// covariance propagated along them). Every other edge's ends move to their nearest kept pose
/// along the chain, as that pose times a constant offset, the chain between them adding its
/// covariance to the edge's. Keeping the loops' ends, the marginals of the poses kept are those
/// of the whole graph to first order (eliminating a chain's inner poses is exact for a linear
/// chain); keeping fewer, the graph's size is the caller's choice, and a loop weighs a little
/// less. `node_of`: each pose's index in the result, or -1; `weights` (per edge, as
/// marginalCovariances takes them; missing ones 1) become the result's.
PoseGraph thinChains(const PoseGraph& graph, const std::vector<bool>& keep,
                     std::vector<int>* node_of, std::vector<double>* weights);

/// Where one optimize() starts beyond the graph's poses: a solve over part of a larger graph
/// (core/backend/team_graph.h) holds its boundary constant and resumes its switches.
struct SolveStart {
  /// Per pose: held constant. Empty (or none set): the first pose only, the gauge.
  std::vector<bool> fixed;
  /// Per edge: the switch variable to start from. Empty: the prior's value for every loop (the
  /// retry of uncertainty_aware_start always starts there).
  std::vector<double> switches;
};

class PoseGraphOptimizer {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit PoseGraphOptimizer(const OptimizerParams& params);

  /// Optimises graph.poses in place from their current values, within `max_time_s` of wall
  /// time (default: params.max_solve_time_s). Throws std::invalid_argument when `start`'s
  /// vectors are neither empty nor one per pose / edge.
  OptimizationResult optimize(PoseGraph& graph, std::optional<double> max_time_s = std::nullopt,
                              const SolveStart& start = {}) const;

  /// Marginal covariances of poses `ids` in their tangent space (as the residuals: [x y theta]
  /// or [x y z, rotation vector], rotation in the pose's frame) at the current estimate, first
  /// pose fixed, loop closures weighted as `weights` (from optimize(); empty: all 1). nullopt
  /// when Ceres cannot compute them (a rank-deficient graph).
  std::optional<std::vector<Eigen::MatrixXd>> marginalCovariances(
      const PoseGraph& graph, const std::vector<int>& ids,
      const std::vector<double>& weights = {}) const;

  /// Sum of squared whitened residuals of every edge, unweighted (0.5 x Ceres' plain cost x 2).
  static double plainCost(const PoseGraph& graph);
  /// chi^2 of one edge at the graph's current estimate.
  static double chi2(const PoseGraph& graph, const PoseGraphEdge& edge);
  /// chi^2 above which a loop is an outlier for the kernels that have no switch (99 %).
  static double outlierChi2(int dimension) { return dimension == 2 ? 11.345 : 16.812; }

  const OptimizerParams& params() const { return params_; }
  /// The value a loop's switch starts from without a SolveStart: its prior's.
  double initialSwitch() const {
    return params_.switch_function == SwitchFunction::kLinear ? 1.0 : 10.0;
  }

 private:
  double switchPriorSigma(int dimension) const;
  double dcsPhi(int dimension) const;
  /// Fills result.weights and result.inliers for the loops.
  void classify(const PoseGraph& graph, const std::vector<double>& switches,
                OptimizationResult& result) const;
  /// One Ceres solve from the graph's poses and `switches` (updated in place), stopped after
  /// `time_limit_s`.
  void solve(PoseGraph& graph, const std::vector<bool>& fixed, std::vector<double>& switches,
             OptimizationResult& result, double time_limit_s) const;

  OptimizerParams params_;
};

}  // namespace ccir_mapping::core::pose_graph
