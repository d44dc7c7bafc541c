#include "ccir_mapping/core/hgmm/gaussian_mixture.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ccir_mapping::core::hgmm {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

/// log N(x; mu, S) for the lower Cholesky factor L of S.
double logGaussian(const Eigen::Vector3d& x, const Eigen::Vector3d& mu, const Eigen::Matrix3d& l) {
  const Eigen::Vector3d z = l.triangularView<Eigen::Lower>().solve(x - mu);
  return -0.5 * (3 * kLog2Pi + z.squaredNorm()) - std::log(l.diagonal().prod());
}

double logSumExp(double a, double b) {
  if (a == -std::numeric_limits<double>::infinity()) return b;
  if (b == -std::numeric_limits<double>::infinity()) return a;
  return a > b ? a + std::log1p(std::exp(b - a)) : b + std::log1p(std::exp(a - b));
}

}  // namespace

double innerProduct(const GaussianMixture& f, const GaussianMixture& g) {
  double sum = 0.0;
  for (const Gaussian& a : f.components()) {
    for (const Gaussian& b : g.components()) {
      // Means farther apart than sqrt(60 trace(S)) are at a squared Mahalanobis distance above
      // 60 (trace >= largest eigenvalue): the term is below e^-30 of its peak. Skipping such
      // pairs spares a scan-sized product most of its 3x3 factorisations.
      const Eigen::Matrix3d s = a.covariance + b.covariance;
      if ((a.mean - b.mean).squaredNorm() > 60.0 * s.trace()) continue;
      const Eigen::LLT<Eigen::Matrix3d> llt(s);
      sum += a.weight * b.weight * std::exp(logGaussian(a.mean, b.mean, llt.matrixL()));
    }
  }
  return sum;
}

GaussianMixture::GaussianMixture(std::vector<Gaussian> components)
    : components_(std::move(components)) {
  for (std::size_t k = 0; k < components_.size(); ++k) {
    const Gaussian& g = components_[k];
    const std::string name = "component " + std::to_string(k);
    if (!std::isfinite(g.weight) || g.weight < 0.0) {
      throw std::invalid_argument(name + ": weight must be finite and >= 0");
    }
    if (!g.mean.allFinite() || !g.covariance.allFinite() ||
        !g.covariance.isApprox(g.covariance.transpose(), 1e-9)) {
      throw std::invalid_argument(name + ": mean and covariance must be finite, symmetric");
    }
    const Eigen::LLT<Eigen::Matrix3d> llt(g.covariance);
    if (llt.info() != Eigen::Success ||
        !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0)) {
      throw std::invalid_argument(name + ": covariance is not positive definite");
    }
    cholesky_.push_back(llt.matrixL());
    log_normaliser_.push_back(std::log(g.weight));
    total_weight_ += g.weight;
  }
  if (!components_.empty() && !(total_weight_ > 0.0)) {
    throw std::invalid_argument("the weights sum to zero");
  }
}

double GaussianMixture::logComponentDensity(std::size_t k, const Eigen::Vector3d& x) const {
  return log_normaliser_[k] + logGaussian(x, components_[k].mean, cholesky_[k]);
}

double GaussianMixture::logDensity(const Eigen::Vector3d& x) const {
  double result = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < components_.size(); ++k) {
    result = logSumExp(result, logComponentDensity(k, x));
  }
  return result;
}

Eigen::MatrixXd GaussianMixture::logComponentDensities(const Points& points) const {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(size()), points.cols());
  for (std::size_t k = 0; k < size(); ++k) {
    const Points z =
        cholesky_[k].triangularView<Eigen::Lower>().solve(points.colwise() - components_[k].mean);
    out.row(static_cast<Eigen::Index>(k)) =
        (log_normaliser_[k] - 1.5 * kLog2Pi - std::log(cholesky_[k].diagonal().prod()) -
         0.5 * z.colwise().squaredNorm().array())
            .matrix();
  }
  return out;
}

double GaussianMixture::meanLogLikelihood(const Points& points) const {
  if (points.cols() == 0) return 0.0;
  if (empty()) return -std::numeric_limits<double>::infinity();
  // log-sum-exp over the components, all points at once (the hierarchy's split test calls this
  // for every node).
  const Eigen::MatrixXd log_density = logComponentDensities(points);
  const Eigen::RowVectorXd peak = log_density.colwise().maxCoeff();
  return (peak.array() + (log_density.rowwise() - peak).array().exp().colwise().sum().log()).mean();
}

Points GaussianMixture::sample(std::size_t n, std::mt19937_64& rng, double max_mahalanobis2,
                               std::vector<std::size_t>* drawn) const {
  Points out(3, static_cast<Eigen::Index>(empty() ? 0 : n));
  if (drawn) drawn->assign(static_cast<std::size_t>(out.cols()), 0);
  if (empty()) return out;
  std::vector<double> weights;
  for (const Gaussian& g : components_) weights.push_back(g.weight);
  std::discrete_distribution<std::size_t> pick(weights.begin(), weights.end());
  std::normal_distribution<double> normal;
  for (Eigen::Index i = 0; i < out.cols(); ++i) {
    const std::size_t k = pick(rng);
    Eigen::Vector3d xi;
    do {
      xi << normal(rng), normal(rng), normal(rng);
    } while (max_mahalanobis2 > 0.0 && xi.squaredNorm() > max_mahalanobis2);
    out.col(i) = components_[k].mean + cholesky_[k] * xi;
    if (drawn) (*drawn)[static_cast<std::size_t>(i)] = k;
  }
  return out;
}

double l2Distance(const GaussianMixture& f, const GaussianMixture& g) {
  // Rounding can leave a tiny negative value for (near-)identical mixtures.
  return std::max(0.0, innerProduct(f, f) - 2.0 * innerProduct(f, g) + innerProduct(g, g));
}

double similarity(const GaussianMixture& f, const GaussianMixture& g) {
  const double norms = innerProduct(f, f) + innerProduct(g, g);
  return norms > 0.0 ? 2.0 * innerProduct(f, g) / norms : 0.0;
}

}  // namespace ccir_mapping::core::hgmm
