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

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/place_recognition/matcher_stage.h"
#include "ccir_mapping/core/pose_graph/loop_closure.h"
#include "ccir_mapping/core/routing/routing_messages.h"
#include "ccir_mapping/core/routing/scan_encoding.h"

namespace ccir_mapping::core::runner {

/// One message on a link; a scan is shared, not copied, between the teammates it goes to.
using TeamMessage = std::variant<place_recognition::KeyframeWords, routing::Offer, routing::Request,
                                 routing::Receipt, pose_graph::LoopClosureData,
                                 std::shared_ptr<const routing::WireScan>>;

/// The Bridge's topic of each alternative, in TeamMessage's order (scans last: bulk).
constexpr int kTeamTopics = 6;
inline int topicOf(const TeamMessage& message) { return static_cast<int>(message.index()); }
inline bool isBulk(int topic) { return topic == kTeamTopics - 1; }
const char* topicName(int topic);

/// Bytes of the ROS message a robot named `robot` publishes for `message` (its frames are
/// "<robot>/map", "<robot>/odom" and the sensor's "<robot>/velodyne").
std::size_t serializedBytes(const TeamMessage& message);
std::size_t serializedBytes(const routing::WireScan& scan);

}  // namespace ccir_mapping::core::runner
