// Robust pose-graph optimisation on Ceres: odometry edges plain, loop closures as switchable
// constraints (Suenderhauf & Protzel) or with a robust loss, the first pose fixed.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/backend/pose_graph.h"

namespace ccir_mapping::core::backend {

enum class SwitchFunction { kLinear, kSigmoid };

struct OptimizerParams {
  RobustKernel kernel = RobustKernel::kSwitchable;
  /// Linear psi(s) = s with s in [0, 1], prior 1 (default); sigmoid psi(s) = 1 / (1 + e^-s) with
  /// s in [-10, 10], prior 10.
  SwitchFunction switch_function = SwitchFunction::kLinear;
  double switch_prior_sigma = 1.0;
  /// DCS phi, in chi^2 units.
  double dcs_phi = 1.0;
  /// Scale of the Cauchy and Huber losses, on the whitened residual norm.
  double loss_scale = 1.0;
  int max_iterations = 200;
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
  std::string summary;
};

class PoseGraphOptimizer {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit PoseGraphOptimizer(const OptimizerParams& params);

  /// Optimises graph.poses in place from their current values.
  OptimizationResult optimize(PoseGraph& graph) const;

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

 private:
  OptimizerParams params_;
};

}  // namespace ccir_mapping::core::backend
