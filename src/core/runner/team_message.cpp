#include "ccir_mapping/core/runner/team_message.h"

namespace ccir_mapping::core::runner {

namespace {

// roscpp's serialisation: a string or array is a uint32 length and its elements; a Header is a
// uint32 seq, a time (two uint32) and its frame_id; a Pose is seven float64.
constexpr std::size_t kLength = 4;
constexpr std::size_t kPose = 7 * 8;
std::size_t text(const std::string& s) { return kLength + s.size(); }
std::size_t header(const std::string& frame_id) { return 4 + 8 + text(frame_id); }

struct Size {
  std::size_t operator()(const place_recognition::KeyframeWords& m) const {
    return header(m.robot + "/velodyne") + text(m.robot) + 8 + text(m.vocabulary_hash) + kLength +
           4 * m.words.size() + 4;
  }
  std::size_t operator()(const routing::Offer& m) const {
    constexpr std::size_t kOfferedScan = 8 + kPose + 4 + 4 + 8;
    return header({}) + text(m.provider) + text(m.requester) + 4 + text(m.provider + "/map") +
           kLength + kOfferedScan * m.scans.size();
  }
  std::size_t operator()(const routing::Request& m) const {
    return header({}) + text(m.requester) + text(m.provider) + 4 + kLength + 8 * m.ids.size();
  }
  std::size_t operator()(const routing::Receipt& m) const {
    return header({}) + text(m.receiver) + text(m.provider) + kLength + 8 * m.ids.size();
  }
  std::size_t operator()(const pose_graph::LoopClosureData& m) const {
    // match_score, new_place_probability, fitness_m2, inliers.
    return header({}) + text(m.robot_from) + 8 + text(m.robot_to) + 8 + 3 * kPose + 36 * 8 + 8 + 8 +
           8 + 4 + text(m.method);
  }
  std::size_t operator()(const routing::WireScan& m) const {
    return header(m.robot + "/velodyne") + text(m.robot) + 8 + text(m.robot + "/odom") + kPose + 4 +
           4 + 1 + 4 + kLength + m.points.size();
  }
  std::size_t operator()(const std::shared_ptr<const routing::WireScan>& m) const {
    return (*this)(*m);
  }
};

}  // namespace

const char* topicName(int topic) {
  static const char* const kNames[kTeamTopics] = {"features", "offers",        "requests",
                                                  "receipts", "loop_closures", "scans"};
  return topic >= 0 && topic < kTeamTopics ? kNames[topic] : "?";
}

std::size_t serializedBytes(const TeamMessage& message) { return std::visit(Size{}, message); }
std::size_t serializedBytes(const routing::WireScan& scan) { return Size{}(scan); }

}  // namespace ccir_mapping::core::runner
