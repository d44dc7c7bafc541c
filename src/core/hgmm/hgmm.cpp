#include "ccir_mapping/core/hgmm/hgmm.h"

#include <cmath>
#include <functional>

#include <Eigen/Cholesky>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/hgmm/em_fitter.h"

namespace ccir_mapping::core::hgmm {
namespace {

/// The columns of `points` whose label is `label`.
Points select(const Points& points, const std::vector<int>& labels, int label) {
  std::vector<Eigen::Index> kept;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] == label) kept.push_back(static_cast<Eigen::Index>(i));
  }
  Points out(3, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i) {
    out.col(static_cast<Eigen::Index>(i)) = points.col(kept[i]);
  }
  return out;
}

/// Mean log-likelihood of `points` under their own maximum-likelihood Gaussian with the
/// covariance floor, in closed form: -(3 ln 2pi + ln|S + fI| + tr((S + fI)^-1 S)) / 2 for the
/// points' scatter S (what EM with one component converges to, without iterating).
double oneGaussianMeanLogLikelihood(const Points& points, double floor_m2) {
  const Eigen::Vector3d mean = points.rowwise().mean();
  const Points centred = points.colwise() - mean;
  const Eigen::Matrix3d scatter = centred * centred.transpose() / double(points.cols());
  const Eigen::Matrix3d covariance = scatter + floor_m2 * Eigen::Matrix3d::Identity();
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  return -0.5 * (3.0 * std::log(2.0 * M_PI) + log_det + llt.solve(scatter).trace());
}

/// Parameters of a mixture of `k` full-covariance 3D Gaussians (weights sum to one).
double parameterCount(std::size_t k) { return 10.0 * double(k) - 1.0; }

}  // namespace

Hgmm Hgmm::build(const Points& points, const HgmmParams& params) {
  validated(params);
  Hgmm hgmm;
  // Adds the fit's components as children of `parent` (weights scaled by `scale`), then splits
  // each further.
  std::function<void(const EmFit&, const Points&, int, int, double)> add =
      [&](const EmFit& fit, const Points& node_points, int parent, int depth, double scale) {
        for (std::size_t k = 0; k < fit.mixture.size(); ++k) {
          HgmmNode node;
          node.gaussian = fit.mixture.components()[k];
          node.gaussian.weight *= scale;
          node.parent = parent;
          node.depth = depth;
          const Points own = select(node_points, fit.labels, static_cast<int>(k));
          node.points = static_cast<std::size_t>(own.cols());
          const int index = static_cast<int>(hgmm.nodes_.size());
          hgmm.nodes_.push_back(node);
          if (parent >= 0) hgmm.nodes_[static_cast<std::size_t>(parent)].children.push_back(index);
          hgmm.depth_ = std::max(hgmm.depth_, depth);
          if (depth >= params.max_depth || own.cols() < params.min_points_to_split) continue;
          EmParams em = params.em;
          em.seed = params.em.seed + static_cast<std::uint64_t>(index) + 1;
          const EmFit children = fitGaussianMixture(own, em);
          if (children.mixture.size() < 2) continue;
          const double n = static_cast<double>(own.cols());
          const double gain = n * (children.mean_log_likelihood -
                                   oneGaussianMeanLogLikelihood(own, em.covariance_floor_m2));
          const double extra = parameterCount(children.mixture.size()) - parameterCount(1);
          if (2.0 * gain <= extra * std::log(n)) continue;
          add(children, own, index, depth + 1, node.gaussian.weight);
        }
      };
  add(fitGaussianMixture(points, params.em), points, -1, 0, 1.0);
  return hgmm;
}

std::vector<int> Hgmm::levelNodes(int level) const {
  std::vector<int> out;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const HgmmNode& node = nodes_[i];
    if (node.depth == level || (node.depth < level && node.children.empty())) {
      out.push_back(static_cast<int>(i));
    }
  }
  return out;
}

GaussianMixture Hgmm::level(int level) const {
  std::vector<Gaussian> components;
  for (const int i : levelNodes(level)) components.push_back(nodes_[std::size_t(i)].gaussian);
  return GaussianMixture(std::move(components));
}

std::size_t Hgmm::components(int level) const { return levelNodes(level).size(); }

std::optional<int> Hgmm::levelWithin(std::size_t budget_bytes) const {
  std::optional<int> best;
  for (int l = 0; l <= depth_ && bytes(l) <= budget_bytes; ++l) best = l;
  return best;
}

}  // namespace ccir_mapping::core::hgmm
