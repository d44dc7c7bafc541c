#include "ccir_mapping/core/place_recognition/matcher_stage.h"

namespace ccir_mapping::core::place_recognition {
namespace {

MatcherStage::Output refused(std::string kind, std::string text) {
  MatcherStage::Output out;
  out.refused.push_back({std::move(kind), std::move(text)});
  return out;
}

}  // namespace

MatcherStage::MatcherStage(std::string robot, const MatcherParams& params,
                           std::shared_ptr<const PlaceModel> model, Hooks hooks)
    : robot_(std::move(robot)), hooks_(std::move(hooks)), matcher_(params, std::move(model)) {}

MatcherStage::MatcherStage(std::string robot, const MatcherParams& params,
                           std::shared_ptr<const PlaceModel> model)
    : MatcherStage(std::move(robot), params, std::move(model), Hooks{}) {}

template <class F>
auto MatcherStage::measured(const char* stage, F&& work) {
  std::optional<decltype(work())> result;
  hooks_.run(stage, [&] { result.emplace(work()); });
  return std::move(*result);
}

MatcherStage::Output MatcherStage::describeOwn(KeyframeId id, Stamp stamp, const Cloud& cloud,
                                               const Pose3& odom_pose,
                                               DescribedKeyframe* described) {
  *described =
      measured("describe", [&] { return matcher_.describeOwn(id, stamp, cloud, odom_pose); });
  Output out;
  const auto descriptors = static_cast<std::uint32_t>(described->scan.features.descriptors.size());
  out.features = KeyframeWords{robot_, id, stamp, vocabularyHash(), described->words, descriptors};
  for (const auto& c : matcher_.teammateCorrespondences(described->words)) {
    out.correspondences.push_back({c.robot, c.keyframe, {{id, c.count}}});
  }
  return out;
}

MatcherStage::Output MatcherStage::matchOwn(DescribedKeyframe described) {
  const KeyframeId id = described.id;
  const auto kept = measured("match", [&] { return matcher_.matchKeptScans(described); });
  const auto places = measured("match", [&] { return matcher_.addOwn(std::move(described)); });
  // Closed once the keyframe is a place, so that each closure carries its odometry pose.
  Output out;
  closeLoop(kept, robot_, id, std::nullopt, out);
  closeLoop(places, robot_, id, std::nullopt, out);
  verifyQueued(out);
  return out;
}

MatcherStage::Output MatcherStage::onTeammateWords(const KeyframeWords& words) {
  auto problem = matcher_.wordsProblem(words.vocabulary_hash, words.words);
  if (words.robot == robot_) problem = {"own", "from this robot itself (bridge loop?)"};
  if (problem) {
    return refused("features (" + problem->kind + ")", "refusing features of " + words.robot +
                                                           " keyframe " + std::to_string(words.id) +
                                                           ": " + problem->text);
  }
  Output out;
  out.correspondences.push_back({words.robot, words.id, matcher_.correspondences(words.words)});
  matcher_.keepTeammateWords(words.robot, words.id, words.words);
  return out;
}

MatcherStage::Output MatcherStage::onTeammateScan(const std::string& robot, KeyframeId id,
                                                  Stamp stamp, const Cloud& cloud,
                                                  const Pose3& odom_pose, bool drawn_from_mixture) {
  if (robot == robot_) {
    return refused("scans (own)",
                   "ignoring scans from this robot itself on the inbox (bridge loop?)");
  }
  auto described = measured("describe", [&] {
    return matcher_.describeTeammate(id, stamp, cloud, odom_pose, drawn_from_mixture);
  });
  Output out;
  closeLoop(measured("match", [&] { return matcher_.matchTeammate(robot, described); }), robot, id,
            described.odom_pose, out);
  matcher_.keepTeammateScan(robot, std::move(described));
  verifyQueued(out);
  return out;
}

void MatcherStage::closeLoop(const std::vector<MatchCandidate>& candidates,
                             const std::string& query_robot, KeyframeId query,
                             const std::optional<Pose3>& query_odom_pose, Output& out) const {
  out.verified += candidates.size();
  if (const MatchCandidate* best = bestAccepted(candidates)) {
    out.loop_closures.push_back(
        matcher_.loopClosure(robot_, *best, query_robot, query, query_odom_pose));
    out.waited_s.push_back(0.0);
  }
}

void MatcherStage::verifyQueued(Output& out) {
  const auto matches = measured("match", [&] { return matcher_.verifyQueued(); });
  out.verified += matches.size();
  for (const auto& m : matches) {
    if (!m.candidate.verification.accepted) continue;
    out.loop_closures.push_back(matcher_.loopClosure(robot_, m.candidate, robot_, m.own));
    out.waited_s.push_back(m.waited_s);
  }
}

}  // namespace ccir_mapping::core::place_recognition
