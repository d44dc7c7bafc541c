// Parameters of place recognition and loop-closure detection.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccir_mapping/core/hgmm/hgmm_params.h"
#include "ccir_mapping/core/hgmm/mixture_registration.h"
#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/scan_context.h"
#include "ccir_mapping/core/registration/verification_params.h"

namespace ccir_mapping::core::place_recognition {

/// FAB-MAP over bags of spin-image words, the histogram-of-descriptors baseline, Scan Context, or
/// Gaussian mixtures registered to each other (thesis section 6.2).
enum class MatchMethod { kFabmap, kHistogram, kScanContext, kHgmm };
constexpr std::string_view kMatchMethodChoices = "fabmap | histogram | scan_context | hgmm";
std::optional<MatchMethod> parseMatchMethod(std::string_view text);
const char* toString(MatchMethod method);

/// Which places method hgmm registers a query's mixture to: the Scan Context search's (their
/// ring_key_candidates nearest, each from the yaw Scan Context found), or every eligible place
/// from 8 headings 45 degrees apart (its cost grows with the places).
enum class MixtureCandidates { kScanContext, kAll };
constexpr std::string_view kMixtureCandidatesChoices = "scan_context | all";
std::optional<MixtureCandidates> parseMixtureCandidates(std::string_view text);
const char* toString(MixtureCandidates candidates);

/// Method hgmm: each keyframe's verification cloud, levelled, becomes an HGMM whose deepest level
/// is kept; a query's mixture is registered to the candidates' (GMM-to-GMM GICP), those accepted
/// (registration.min_similarity) are ranked by the similarity of the registered mixtures, and
/// the best verified from the registered transform.
struct MixtureMatchParams {
  hgmm::HgmmParams model;
  hgmm::RegistrationParams registration;
  MixtureCandidates candidates = MixtureCandidates::kScanContext;
  std::vector<std::string> validate() const;
};

/// Where a query's candidates come from (PoseGate, VerificationQueue). With a pose prior (own
/// loops from odometry; a teammate's keyframes once an accepted closure anchors its frame) only
/// places within reach_m of the predicted position plus the drift allowance (1 m +
/// own_loop_gate_m_per_m x the path since the anchor, at most max_drift_m) are candidates, and
/// the gated_candidates best-ranked of them are verified at once. Without one, each query's
/// max_candidates best-ranked places wait in a queue and prior_free_verifications_per_s of
/// them, each query's best-ranked first, are verified per second of mission time.
struct SearchParams {
  double reach_m = 15.0;
  double max_drift_m = 60.0;
  int gated_candidates = 3;
  /// 0: no budget, each prior-free query verifies its candidates at once (the cost then grows
  /// with the places and the teammates).
  double prior_free_verifications_per_s = 2.0;
  /// Queued candidates older than this (mission time) are dropped unverified.
  double prior_free_horizon_s = 60.0;
  std::vector<std::string> validate() const;
};

struct MatcherParams {
  MatchMethod method = MatchMethod::kFabmap;
  /// Vocabulary and Chow-Liu model directory; empty = the model shipped with the package.
  std::string model_dir;
  /// c_k, the correspondences of a local keyframe with a query, counts the words they share; a
  /// keyframe with fewer is never a candidate nor reported to teammates (c_k,min).
  int min_correspondences = 3;
  /// Own keyframes younger than this are never matched against (temporal exclusion window).
  double loop_exclusion_s = 30.0;
  /// Best-ranked places of each query without a pose prior that are verified (queued when
  /// search.prior_free_verifications_per_s is set): in an aliased mine the true place is rarely
  /// first.
  int max_candidates = 20;
  /// FAB-MAP's decision rule: of those, only places whose posterior is at least this are
  /// verified (0: the best-ranked max_candidates, whatever their probability).
  double min_place_probability = 0.0;
  /// FAB-MAP's detector model, smoothing and priors.
  FabMapParams fabmap;
  /// Scan Context's grid and search.
  ScanContextParams scan_context;
  /// Method hgmm's mixtures and their registration.
  MixtureMatchParams hgmm;
  /// Places (own keyframes and teammates' scans) kept ready for verification, the most
  /// recently used: the others keep ~1/6 of it (their clouds, features and GICP covariances in
  /// single precision, ~0.25 MB) and are made ready again when a query ranks them by rebuilding
  /// their search trees, so the Matcher's memory grows by that per place instead of ~1.5 MB.
  int complete_places = 100;
  /// Own loop closures must agree with odometry within 1 m + this x the path between the two
  /// keyframes, and 0.2 rad + own_loop_gate_rad_per_m x path; 0 turns the check off, and with
  /// it the pose gate of the search (which takes this as odometry's drift per metre).
  double own_loop_gate_m_per_m = 0.1;
  double own_loop_gate_rad_per_m = 0.01;
  /// Where candidates come from, and the verification budget.
  SearchParams search;
  /// Loop-closure verification: the acceptance tests (minimum inliers, fitness, wall overlap,
  /// free space) and how the scans are aligned; the same struct bench_place_recognition and
  /// eval_place_recognition measure.
  registration::VerificationParams verification;

  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::place_recognition
