// Dynamic covariance scaling (Agarwal et al., ICRA 2013) as a Ceres loss. Ceres has no DCS or
// Geman-McClure loss, hence this one; rho is the integral of the weight, so the solver's step
// acceptance sees the cost it minimises (g2o's kernel is not consistent there).
#pragma once

#include <ceres/loss_function.h>

namespace ccir_mapping::core::pose_graph {

/// With s = chi^2: rho = s up to phi, then 3 phi - 4 phi^2 / (phi + s), bounded by 3 phi.
/// rho' = (2 phi / (phi + s))^2 = the DCS scale squared; rho, rho' continuous at s = phi.
class DcsLoss : public ceres::LossFunction {
 public:
  explicit DcsLoss(double phi) : phi_(phi) {}
  void Evaluate(double s, double rho[3]) const override;

  /// The DCS scale min(1, 2 phi / (phi + chi^2)) a residual gets.
  static double scale(double phi, double chi2);

 private:
  double phi_;
};

}  // namespace ccir_mapping::core::pose_graph
