#include "ccir_mapping/core/backend/team_disagreement.h"

#include <cmath>

namespace ccir_mapping::core::backend {
namespace {

bool within(const Pose3& delta, const BackendParams& params) {
  return delta.translation().norm() <= params.team_disagreement_m &&
         Eigen::AngleAxisd(delta.linear()).angle() * 180 / M_PI <= params.team_disagreement_deg;
}

}  // namespace

TeamDisagreement judgeDisagreement(const Pose3& graph, const Pose3& placed_with, const Pose3& em,
                                   int accepted, int em_inliers, const BackendParams& params) {
  TeamDisagreement result;
  const Pose3 delta = graph.inverse() * em;
  result.shift_m = delta.translation().norm();
  result.turn_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180 / M_PI;
  using Verdict = TeamDisagreement::Verdict;
  if (em_inliers <= 0 || within(delta, params)) {
    result.verdict = Verdict::kAgree;
  } else if (accepted + params.team_inlier_margin >= em_inliers) {
    result.verdict = Verdict::kKeepGraph;
  } else if (within(placed_with.inverse() * em, params)) {
    result.verdict = Verdict::kTriedBefore;
  } else {
    result.verdict = Verdict::kPlaceAgain;
  }
  return result;
}

}  // namespace ccir_mapping::core::backend
