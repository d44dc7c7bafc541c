#include "ccir_mapping/core/hgmm/gaussian_mixture.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

namespace ccir_mapping::core::hgmm {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

/// log N(x; mu, S) for the lower Cholesky factor L of S.
double logGaussian(const Eigen::Vector3d& x, const Eigen::Vector3d& mu, const Eigen::Matrix3d& l) {
  const Eigen::Vector3d z = l.triangularView<Eigen::Lower>().solve(x - mu);
  return -0.5 * (3 * kLog2Pi + z.squaredNorm()) - std::log(l.diagonal().prod());
}

/// Terms this far below the largest are left out of sums of exponentials: e^-36.04 is the
/// double's epsilon, so adding them to the largest term (1) changes nothing.
const double kNegligibleLog = std::log(std::numeric_limits<double>::epsilon());

double logSumExp(double a, double b) {
  if (a == -std::numeric_limits<double>::infinity()) return b;
  if (b == -std::numeric_limits<double>::infinity()) return a;
  return a > b ? a + std::log1p(std::exp(b - a)) : b + std::log1p(std::exp(a - b));
}

/// w_a w_b N(mu_a; mu_b, S_a + S_b), or 0 at a squared Mahalanobis distance above 60 (the term
/// below e^-30 of its peak). Means farther apart than sqrt(60 trace(S)) are rejected before any
/// 3x3 algebra (trace >= largest eigenvalue), and the inverse is by cofactors: a scan-sized
/// product has hundreds of thousands of pairs.
double gaussianProduct(const Gaussian& a, const Gaussian& b) {
  const Eigen::Vector3d d = a.mean - b.mean;
  const double d2 = d.squaredNorm();
  if (d2 > 60.0 * (a.covariance.trace() + b.covariance.trace())) return 0.0;
  const Eigen::Matrix3d s = a.covariance + b.covariance;
  const double det = s.determinant();
  const double m = d.dot(s.inverse() * d);
  if (m > 60.0) return 0.0;
  constexpr double kEightPiCubed = 248.05021344239853;  // (2 pi)^3
  return a.weight * b.weight * std::exp(-0.5 * m) / std::sqrt(kEightPiCubed * det);
}

}  // namespace

double innerProduct(const GaussianMixture& f, const GaussianMixture& g) {
  // gaussianProduct's distance gate for one component against all of g at once, on packed
  // arrays (vectorised): of a scan's ~360 k pairs about 10 % pass it, so the gate is the cost.
  const auto& b = g.components();
  const Eigen::Index n = static_cast<Eigen::Index>(b.size());
  Eigen::Array3Xd means(3, n);
  Eigen::ArrayXd traces(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    means.col(j) = b[std::size_t(j)].mean.array();
    traces(j) = b[std::size_t(j)].covariance.trace();
  }
  const bool same = &f == &g;  // symmetric: each pair once
  double sum = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Gaussian& x = f.components()[i];
    const Eigen::Index first = same ? Eigen::Index(i) + 1 : 0;
    const Eigen::ArrayXd margin = (means.rightCols(n - first).colwise() - x.mean.array())
                                      .square()
                                      .colwise()
                                      .sum()
                                      .transpose() -
                                  60.0 * (traces.tail(n - first) + x.covariance.trace());
    if (same) sum += gaussianProduct(x, x);
    for (Eigen::Index j = 0; j < margin.size(); ++j) {
      if (margin(j) <= 0.0)
        sum += (same ? 2.0 : 1.0) * gaussianProduct(x, b[std::size_t(first + j)]);
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
    inverse_cholesky_.push_back(
        cholesky_.back().triangularView<Eigen::Lower>().solve(Eigen::Matrix3d::Identity()));
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
    const Eigen::Index row = static_cast<Eigen::Index>(k);
    const double constant =
        log_normaliser_[k] - 1.5 * kLog2Pi - std::log(cholesky_[k].diagonal().prod());
    const Eigen::Matrix3d& inverse = inverse_cholesky_[k];
    const Eigen::Vector3d& mean = components_[k].mean;
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      out(row, i) = constant - 0.5 * (inverse * (points.col(i) - mean)).squaredNorm();
    }
  }
  return out;
}

double GaussianMixture::meanLogLikelihood(const Points& points) const {
  if (points.cols() == 0) return 0.0;
  if (empty()) return -std::numeric_limits<double>::infinity();
  // log-sum-exp over the components, all points at once (the hierarchy's split test calls this
  // for every node).
  return logSumExpColumns(logComponentDensities(points)).mean();
}

Eigen::RowVectorXd logSumExpColumns(const Eigen::MatrixXd& log_values) {
  Eigen::RowVectorXd out(log_values.cols());
  for (Eigen::Index i = 0; i < log_values.cols(); ++i) {
    const double peak = log_values.col(i).maxCoeff();
    double sum = 0.0;
    for (Eigen::Index k = 0; k < log_values.rows(); ++k) {
      const double v = log_values(k, i) - peak;
      if (v > kNegligibleLog) sum += std::exp(v);
    }
    out(i) = peak + std::log(sum);
  }
  return out;
}

Eigen::MatrixXd normalisedExp(const Eigen::MatrixXd& log_values,
                              const Eigen::RowVectorXd& column_log_sums) {
  Eigen::MatrixXd out(log_values.rows(), log_values.cols());
  for (Eigen::Index i = 0; i < log_values.cols(); ++i) {
    for (Eigen::Index k = 0; k < log_values.rows(); ++k) {
      const double v = log_values(k, i) - column_log_sums(i);
      out(k, i) = v > kNegligibleLog ? std::exp(v) : 0.0;
    }
  }
  return out;
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
