#include "ccir_mapping/core/hgmm/novelty_keyframes.h"

#include <algorithm>
#include <numeric>
#include <random>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/hgmm/mixture_registration.h"

namespace ccir_mapping::core::hgmm {

std::vector<std::string> NoveltyParams::validate() const {
  ParamCheck check;
  for (const auto& e : hgmm.validate()) check.require(false, e);
  check.inRange("stored_level", stored_level, 0, 10);
  check.inHalfOpenRange("explained_mahalanobis2", explained_mahalanobis2, 0.0, 1000.0);
  check.inRange("min_explained_share", min_explained_share, 0.0, 1.0);
  check.inRange("test_points", test_points, 1, 10000000);
  return check.errors();
}

NoveltyKeyframes::NoveltyKeyframes(const NoveltyParams& params) : params_(validated(params)) {}

double NoveltyKeyframes::explainedShare(const Points& points, const Pose3& pose) const {
  if (gates_.empty() || points.cols() == 0) return 0.0;
  std::vector<Eigen::Index> tested(static_cast<std::size_t>(points.cols()));
  std::iota(tested.begin(), tested.end(), 0);
  if (points.cols() > params_.test_points) {
    std::mt19937_64 rng(1);
    std::shuffle(tested.begin(), tested.end(), rng);
    tested.resize(static_cast<std::size_t>(params_.test_points));
  }
  // Every stored Gaussian is tested: a few thousand, against a few hundred points.
  std::size_t explained = 0;
  for (const Eigen::Index i : tested) {
    const Eigen::Vector3d x = pose * points.col(i);
    explained += std::any_of(gates_.begin(), gates_.end(), [&](const auto& gate) {
      return gate.second.template triangularView<Eigen::Lower>()
                 .solve(x - gate.first)
                 .squaredNorm() <= params_.explained_mahalanobis2;
    });
  }
  return double(explained) / double(tested.size());
}

bool NoveltyKeyframes::offer(const Points& points, const Pose3& pose) {
  if (points.cols() == 0 || explainedShare(points, pose) >= params_.min_explained_share) {
    return false;
  }
  const Hgmm hgmm = Hgmm::build(points, params_.hgmm);
  const int level = std::min(params_.stored_level, hgmm.depth());
  keyframes_.push_back(transformed(hgmm.level(level), pose));
  bytes_ += hgmm.bytes(level);
  for (const Gaussian& g : keyframes_.back().components()) {
    gates_.emplace_back(g.mean, Eigen::LLT<Eigen::Matrix3d>(g.covariance).matrixL());
  }
  return true;
}

}  // namespace ccir_mapping::core::hgmm
