#include "ccir_mapping/core/hgmm/em_fitter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::hgmm {
namespace {

/// k-means++ (Arthur & Vassilvitskii 2007): each next centre drawn with probability
/// proportional to the squared distance to the nearest centre so far.
std::vector<Eigen::Vector3d> seedCentres(const Points& points, int k, std::mt19937_64& rng) {
  const Eigen::Index n = points.cols();
  std::vector<Eigen::Vector3d> centres{
      points.col(std::uniform_int_distribution<Eigen::Index>(0, n - 1)(rng))};
  Eigen::ArrayXd nearest = (points.colwise() - centres[0]).colwise().squaredNorm().transpose();
  while (static_cast<int>(centres.size()) < k && nearest.sum() > 0.0) {
    std::discrete_distribution<Eigen::Index> draw(nearest.data(), nearest.data() + n);
    centres.push_back(points.col(draw(rng)));
    nearest = nearest.min(
        (points.colwise() - centres.back()).colwise().squaredNorm().transpose().array());
  }
  return centres;  // fewer than k when the points have fewer distinct positions
}

/// Weights, means and covariances from responsibilities (K x n, columns summing to 1);
/// components explaining less than one point are dropped.
std::vector<Gaussian> maximise(const Points& points, const Eigen::MatrixXd& responsibility,
                               double floor_m2) {
  std::vector<Gaussian> components;
  const double n = static_cast<double>(points.cols());
  // Two passes per component over the points it explains: most responsibilities are exactly 0
  // (normalisedExp), so this is cheaper than dense products over every point.
  for (Eigen::Index k = 0; k < responsibility.rows(); ++k) {
    double mass = 0.0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      const double r = responsibility(k, i);
      if (r == 0.0) continue;
      mass += r;
      sum += r * points.col(i);
    }
    if (!(mass >= 1.0)) continue;
    Gaussian g;
    g.weight = mass / n;
    g.mean = sum / mass;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      const double r = responsibility(k, i);
      if (r == 0.0) continue;
      const Eigen::Vector3d d = points.col(i) - g.mean;
      scatter.noalias() += r * d * d.transpose();
    }
    g.covariance = scatter / mass;
    g.covariance = 0.5 * (g.covariance + g.covariance.transpose());
    g.covariance.diagonal().array() += floor_m2;
    components.push_back(g);
  }
  double total = 0.0;
  for (const Gaussian& g : components) total += g.weight;
  for (Gaussian& g : components) g.weight /= total;
  return components;
}

}  // namespace

EmFit fitGaussianMixture(const Points& all_points, const EmParams& params) {
  validated(params);
  if (all_points.cols() == 0 || !all_points.allFinite()) {
    throw std::invalid_argument("fitGaussianMixture needs finite points");
  }
  std::mt19937_64 rng(params.seed);
  Points subset;
  if (all_points.cols() > params.max_points) {
    std::vector<Eigen::Index> order(static_cast<std::size_t>(all_points.cols()));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    subset.resize(3, params.max_points);
    for (int i = 0; i < params.max_points; ++i)
      subset.col(i) = all_points.col(order[std::size_t(i)]);
  }
  const Points& points = all_points.cols() > params.max_points ? subset : all_points;
  const auto centres =
      seedCentres(points, std::min<int>(params.components, int(points.cols())), rng);
  // Hard assignment to the nearest centre starts EM.
  Eigen::MatrixXd responsibility =
      Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(centres.size()), points.cols());
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    Eigen::Index best = 0;
    double best_d2 = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < centres.size(); ++k) {
      const double d2 = (points.col(i) - centres[k]).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = static_cast<Eigen::Index>(k);
    }
    responsibility(best, i) = 1.0;
  }
  std::vector<Gaussian> mixture = maximise(points, responsibility, params.covariance_floor_m2);
  EmFit fit;
  Eigen::MatrixXd log_density;
  for (int iteration = 0; iteration < params.max_iterations; ++iteration) {
    log_density = GaussianMixture(mixture).logComponentDensities(points);
    const Eigen::RowVectorXd log_sum = logSumExpColumns(log_density);
    fit.log_likelihoods.push_back(log_sum.mean());
    const std::size_t done = fit.log_likelihoods.size();
    if (done > 1 &&
        fit.log_likelihoods[done - 1] - fit.log_likelihoods[done - 2] < params.tolerance) {
      break;
    }
    responsibility = normalisedExp(log_density, log_sum);
    mixture = maximise(points, responsibility, params.covariance_floor_m2);
  }
  log_density = GaussianMixture(mixture).logComponentDensities(all_points);
  fit.labels.resize(static_cast<std::size_t>(all_points.cols()));
  for (Eigen::Index i = 0; i < all_points.cols(); ++i) {
    Eigen::Index best = 0;
    log_density.col(i).maxCoeff(&best);
    fit.labels[static_cast<std::size_t>(i)] = static_cast<int>(best);
  }
  fit.mean_log_likelihood = logSumExpColumns(log_density).mean();
  fit.mixture = GaussianMixture(std::move(mixture));
  return fit;
}

}  // namespace ccir_mapping::core::hgmm
