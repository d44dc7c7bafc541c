// What robots send each other in a team run: the same six outbox topics as the Bridge forwards
// (word sets, offers, requests, receipts, inter-robot loop closures, scans), as plain data, and
// how many bytes each takes serialised as the ROS message the nodelets publish, so that a link
// carries what the bridged ROS path carries (test_runner_message_sizes checks every size
// against roscpp's serialisation).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "ccir_mapping/core/backend/loop_closure.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/routing/routing_messages.h"

namespace ccir_mapping::core::runner {

/// A keyframe's word set (KeyframeFeatures).
struct WordsMessage {
  std::string robot;
  KeyframeId id = 0;
  Stamp stamp = 0;
  std::string vocabulary_hash;
  std::vector<std::uint32_t> words;
  std::uint32_t descriptor_count = 0;
};

/// A keyframe's wire form (SharedScan): routing::encodeKeyframeScan's bytes and what comes with
/// them.
struct WireScan {
  std::string robot;
  KeyframeId id = 0;
  Stamp stamp = 0;
  Pose3 odom_pose = Pose3::Identity();
  float travelled_m = 0.0F;
  float rotated_rad = 0.0F;
  routing::ScanEncoding encoding = routing::ScanEncoding::kCloud;
  std::uint32_t point_count = 0;
  std::vector<std::uint8_t> points;
};

/// One message on a link; a scan is shared, not copied, between the teammates it goes to.
using TeamMessage = std::variant<WordsMessage, routing::Offer, routing::Request, routing::Receipt,
                                 backend::LoopClosureData, std::shared_ptr<const WireScan>>;

/// The Bridge's topic of each alternative, in TeamMessage's order (scans last: bulk).
constexpr int kTeamTopics = 6;
inline int topicOf(const TeamMessage& message) { return static_cast<int>(message.index()); }
inline bool isBulk(int topic) { return topic == kTeamTopics - 1; }
const char* topicName(int topic);

/// Bytes of the ROS message a robot named `robot` publishes for `message` (its frames are
/// "<robot>/map", "<robot>/odom" and the sensor's "<robot>/velodyne").
std::size_t serializedBytes(const TeamMessage& message);
std::size_t serializedBytes(const WireScan& scan);

}  // namespace ccir_mapping::core::runner
