// What the team graph does when a teammate's EM transform differs from the graph's.
#pragma once

#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::backend {

struct TeamDisagreement {
  enum class Verdict {
    kAgree,        ///< within team_disagreement_m / _deg, or no judged closure backs the EM
    kKeepGraph,    ///< the graph's switches accept about as many closures as the EM
    kTriedBefore,  ///< the EM is ahead, but the teammate was placed with that transform already
    kPlaceAgain,   ///< the EM is ahead by more than team_inlier_margin: place the teammate anew
  };
  Verdict verdict = Verdict::kAgree;
  double shift_m = 0.0;  ///< between the graph's transform and the EM's
  double turn_deg = 0.0;
};

/// `graph`: the teammate's transform as the graph has solved it; `placed_with`: the transform
/// it was last placed with; `em`: the EM's. `accepted`: the closures the graph's switches
/// accept; `em_inliers`: the EM's inliers among the closures the graph has judged (those since
/// the last solve only the EM has seen: counted, they would outvote the graph at every solve).
/// The graph moved away from `placed_with` once already: placing it there again would only
/// repeat that, and a full solve, at every period.
TeamDisagreement judgeDisagreement(const Pose3& graph, const Pose3& placed_with, const Pose3& em,
                                   int accepted, int em_inliers, const BackendParams& params);

}  // namespace ccir_mapping::core::backend
