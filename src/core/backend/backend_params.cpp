#include "ccir_mapping/core/backend/backend_params.h"

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::backend {
std::vector<std::string> BackendParams::validate() const {
  ParamCheck check;
  check.inRange("switch_prior_sigma", switch_prior_sigma, 0.0, 100.0);
  check.inHalfOpenRange("odom_sigma_m_per_m", odometry.sigma_m_per_m, 0.0, 10.0);
  check.inHalfOpenRange("odom_sigma_rad_per_m", odometry.sigma_rad_per_m, 0.0, 10.0);
  check.inRange("odom_sigma_rad_per_rad", odometry.sigma_rad_per_rad, 0.0, 10.0);
  check.inRange("min_team_inliers", min_team_inliers, 3, 100000);
  check.inRange("team_inlier_margin", team_inlier_margin, 0, 100000);
  check.inHalfOpenRange("team_disagreement_m", team_disagreement_m, 0.0, 1000.0);
  check.inHalfOpenRange("team_disagreement_deg", team_disagreement_deg, 0.0, 180.0);
  check.inRange("optimize_period_s", optimize_period_s, 0.01, 3600.0);
  check.inRange("solve_window_keyframes", solve_window_keyframes, 0, 1000000);
  check.inRange("full_solve_period_s", full_solve_period_s, 0.0, 86400.0);
  check.inRange("revisit_loop_error_m", revisit_loop_error_m, 0.0, 1e6);
  check.inRange("uncertainty_period_s", uncertainty_period_s, 0.0, 3600.0);
  check.inRange("max_solve_time_s", max_solve_time_s, 0.001, 60.0);
  check.inRange("max_iterations", max_iterations, 1, 10000);
  return check.errors();
}

}  // namespace ccir_mapping::core::backend
