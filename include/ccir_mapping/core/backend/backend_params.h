// Parameters of the pose-graph back end.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/pose_graph/odometry_uncertainty.h"
#include "ccir_mapping/core/pose_graph/robust_kernel.h"

namespace ccir_mapping::core::backend {

struct BackendParams {
  pose_graph::RobustKernel robust_kernel = pose_graph::RobustKernel::kSwitchable;
  /// Standard deviation of the prior that pulls each switch variable towards 1; 0: auto (a loop
  /// as likely as its covariance says stays on, see pose_graph_optimizer.h).
  double switch_prior_sigma = 0.0;
  /// Odometry between keyframes (odom_sigma_m_per_m, odom_sigma_rad_per_m,
  /// odom_sigma_rad_per_rad).
  pose_graph::OdometryNoise odometry;
  /// A team transform needs this many inter-robot loop closures agreeing, and this many more
  /// than any other transform.
  int min_team_inliers = 10;
  int team_inlier_margin = 3;
  /// Teammates whose transform is found join this robot's graph: their keyframes optimised with
  /// its own, inter-robot loop closures as switchable constraints (core/backend/team_graph.h).
  /// false: teammates are placed with the EM transform alone (kept for comparison).
  bool team_graph = true;
  /// A later EM transform that differs from the graph's by more than this is a disagreement
  /// (logged and resolved, see TeamGraph::optimize).
  double team_disagreement_m = 1.0;
  double team_disagreement_deg = 5.0;
  /// The back end looks at what arrived at this period: new keyframes are placed by odometry, and
  /// the graph is solved when a loop closure arrived (or a keyframe one refers to, or a teammate
  /// joined): at most one solve per period.
  double optimize_period_s = 1.0;
  /// Between full solves, a solve frees each robot's newest this many keyframes (and those
  /// placed since the last solve); this robot's older ones are held, each teammate's older ones
  /// move in rigid blocks, and every loop's switch resumes from the last solve: a new loop's
  /// correction goes into the recent drift. A teammate joining or placed again and
  /// full_solve_period_s make the solve a full one. 0: every solve is full.
  int solve_window_keyframes = 100;
  /// A new own loop with neither keyframe free, or that the current estimate misses by more
  /// than this (its translation error plus its rotation error times 10 m, where its scan's walls
  /// are), frees every own keyframe back to its older end: a window would bend only its newest
  /// keyframes to a revisit's whole drift (a teammate's keyframes and blocks take an
  /// inter-robot loop's).
  double revisit_loop_error_m = 1.0;
  /// Mission time between full solves (every pose and switch free, switches from their prior),
  /// the reference the windowed ones drift from; only when a windowed solve happened since.
  double full_solve_period_s = 30.0;
  /// u_k, the own keyframes' marginal covariances (a ceres::Covariance over the graph thinned to
  /// every 10th keyframe and the loops' ends), are computed at most this often in mission time;
  /// between, a newer keyframe's is the newest computed one's plus the odometry drift since.
  double uncertainty_period_s = 10.0;
  /// Upper bound on one optimisation's wall time.
  double max_solve_time_s = 0.5;
  int max_iterations = 50;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::backend
