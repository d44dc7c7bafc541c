// A Gaussian mixture over 3D points: density, likelihood of a cloud, sampling, and the closed-form
// L2 distance between two mixtures (algorithms.md section 6.2). Densities are computed in double
// and in log space. Written here: none of our libraries has a 3D GMM with these operations
// (OpenCV's cv::ml::EM fits one but neither samples nor compares mixtures).
#pragma once

#include <cstddef>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace ccir_mapping::core::hgmm {

/// Points as columns.
using Points = Eigen::Matrix3Xd;

struct Gaussian {
  double weight = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

class GaussianMixture {
 public:
  GaussianMixture() = default;
  /// Throws std::invalid_argument when a weight is negative or not finite, the weights do not
  /// sum to a positive value, or a covariance is not symmetric positive definite.
  explicit GaussianMixture(std::vector<Gaussian> components);

  const std::vector<Gaussian>& components() const { return components_; }
  std::size_t size() const { return components_.size(); }
  bool empty() const { return components_.empty(); }
  /// Sum of the weights (1 for a normalised mixture).
  double totalWeight() const { return total_weight_; }

  /// log of the density sum_k w_k N(x | mu_k, Sigma_k); -inf for an empty mixture.
  double logDensity(const Eigen::Vector3d& x) const;
  /// log of component k's weighted density w_k N(x | mu_k, Sigma_k).
  double logComponentDensity(std::size_t k, const Eigen::Vector3d& x) const;
  /// log(w_k N(x_i | mu_k, Sigma_k)) for every component k (row) and point i (column).
  Eigen::MatrixXd logComponentDensities(const Points& points) const;
  /// Mean over the points of logDensity.
  double meanLogLikelihood(const Points& points) const;

  /// `n` points: each from a component drawn by weight, x = mu + L xi with L L^T = Sigma. With
  /// max_mahalanobis2 > 0 a draw farther than that (squared Mahalanobis distance; 7.81 is the
  /// 95 % chi-square quantile in 3D) is drawn again, so flat Gaussians do not spray points off
  /// their surface. Deterministic for a given rng state. With `drawn`, also the component each
  /// point came from.
  Points sample(std::size_t n, std::mt19937_64& rng, double max_mahalanobis2 = 7.81,
                std::vector<std::size_t>* drawn = nullptr) const;

 private:
  std::vector<Gaussian> components_;
  std::vector<Eigen::Matrix3d> cholesky_;          // lower factors L
  std::vector<Eigen::Matrix3d> inverse_cholesky_;  // L^-1: a 3x3 product per cloud, not a solve
  std::vector<double> log_normaliser_;             // log w_k
  double total_weight_ = 0.0;
};

/// log sum_k exp(v_ki) of each column i, terms below the double's epsilon times the column's
/// largest left out: they change no digit, and skipping them spares most of the exponentials (a
/// point belongs to one or two of a mixture's components).
Eigen::RowVectorXd logSumExpColumns(const Eigen::MatrixXd& log_values);

/// exp(v_ki - column_log_sums_i), 0 where that is below the double's epsilon: EM's
/// responsibilities.
Eigen::MatrixXd normalisedExp(const Eigen::MatrixXd& log_values,
                              const Eigen::RowVectorXd& column_log_sums);

/// Closed-form L2 distance between densities, integral (f - g)^2, from Gaussian products:
/// sum_ij a_i a_j N(mu_i; mu_j, S_i + S_j) - 2 sum_ij a_i b_j N(mu_i; nu_j, S_i + T_j) +
/// sum_ij b_i b_j N(nu_i; nu_j, T_i + T_j). Zero for identical mixtures, symmetric.
double l2Distance(const GaussianMixture& f, const GaussianMixture& g);

/// The integral of f g: sum_ij a_i b_j N(mu_i; nu_j, S_i + T_j), pairs at a squared
/// Mahalanobis distance above 60 left out (each below e^-30 of its peak).
double innerProduct(const GaussianMixture& f, const GaussianMixture& g);

/// 2 <f, g> / (<f, f> + <g, g>) = 1 - L2 / (<f, f> + <g, g>): 1 for identical mixtures, 0 for
/// disjoint ones, symmetric; what a place's mixture and a registered query's share.
double similarity(const GaussianMixture& f, const GaussianMixture& g);

}  // namespace ccir_mapping::core::hgmm
