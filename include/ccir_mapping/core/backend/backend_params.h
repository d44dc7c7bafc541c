// Parameters of the pose-graph back end.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccir_mapping/core/backend/odometry_uncertainty.h"

namespace ccir_mapping::core::backend {

/// How loop closures enter the pose graph: switchable constraints (default), plain least
/// squares, Ceres' Cauchy or Huber losses, or dynamic covariance scaling.
enum class RobustKernel { kSwitchable, kNone, kCauchy, kHuber, kDcs };
constexpr std::string_view kRobustKernelChoices = "switchable | none | cauchy | huber | dcs";
std::optional<RobustKernel> parseRobustKernel(std::string_view text);
const char* toString(RobustKernel kernel);

struct BackendParams {
  RobustKernel robust_kernel = RobustKernel::kSwitchable;
  /// Standard deviation of the prior that pulls each switch variable towards 1; 0: auto (a loop
  /// as likely as its covariance says stays on, see pose_graph_optimizer.h).
  double switch_prior_sigma = 0.0;
  /// Odometry between keyframes (odom_sigma_m_per_m, odom_sigma_rad_per_m,
  /// odom_sigma_rad_per_rad).
  OdometryNoise odometry;
  /// A team transform needs this many inter-robot loop closures agreeing, and this many more
  /// than any other transform.
  int min_team_inliers = 10;
  int team_inlier_margin = 3;
  /// Teammates whose transform is found join this robot's graph: their keyframes optimised with
  /// its own, inter-robot loop closures as switchable constraints (core/team/team_graph.h).
  /// false: teammates are placed with the EM transform alone (kept for comparison).
  bool team_graph = true;
  /// A later EM transform that differs from the graph's by more than this is a disagreement
  /// (logged and resolved, see TeamGraph::optimize).
  double team_disagreement_m = 1.0;
  double team_disagreement_deg = 5.0;
  /// The graph is re-optimised at this period (and when a loop closure arrives).
  double optimize_period_s = 1.0;
  /// Upper bound on one optimisation's wall time.
  double max_solve_time_s = 0.5;
  int max_iterations = 50;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::backend
