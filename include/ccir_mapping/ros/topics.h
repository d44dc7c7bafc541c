// Default topic names, all relative to the robot's namespace; expected to be remapped as needed.
#pragma once

#include <string>

namespace ccir_mapping::topics {

// Sensor input.
constexpr char kVelodynePoints[] = "velodyne_points";
constexpr char kOdometry[] = "odom";

// Inside one robot's manager (zero-copy).
constexpr char kKeyframes[] = "keyframes";
constexpr char kFeatures[] = "features";
constexpr char kCorrespondences[] = "correspondences";
constexpr char kLoopClosures[] = "loop_closures";
constexpr char kTrajectory[] = "trajectory";
constexpr char kKeyframeUncertainty[] = "keyframe_uncertainty";
/// Teammates' scans, decoded from their wire form by the Broker.
constexpr char kTeammateScans[] = "teammate_scans";
constexpr char kTeamTransforms[] = "team_transforms";
/// Teammates' keyframes as this robot's team graph places them (TeamKeyframePoses).
constexpr char kTeamKeyframePoses[] = "team_keyframe_poses";
constexpr char kMapCloud[] = "map_cloud";
constexpr char kMapStats[] = "map_stats";
constexpr char kLoopClosureMarkers[] = "loop_closure_markers";
constexpr char kBrokerStats[] = "broker_stats";
constexpr char kLinkStats[] = "link_stats";

// To teammates, through the Bridge.
constexpr char kOutboxFeatures[] = "outbox/features";
constexpr char kOutboxOffers[] = "outbox/offers";
constexpr char kOutboxRequests[] = "outbox/requests";
constexpr char kOutboxScans[] = "outbox/scans";
constexpr char kOutboxReceipts[] = "outbox/receipts";
/// Inter-robot loop closures this robot found, to every teammate (each uses those with it).
constexpr char kOutboxLoopClosures[] = "outbox/loop_closures";

/// "outbox/to/<peer>/<rest>": what the Bridge carries to that peer alone, as "inbox/<rest>".
inline std::string outboxTo(const std::string& peer, const std::string& rest) {
  return "outbox/to/" + peer + "/" + rest;
}

// From teammates, republished by the Bridge.
constexpr char kInboxFeatures[] = "inbox/features";
constexpr char kInboxOffers[] = "inbox/offers";
constexpr char kInboxRequests[] = "inbox/requests";
constexpr char kInboxScans[] = "inbox/scans";
constexpr char kInboxReceipts[] = "inbox/receipts";
constexpr char kInboxLoopClosures[] = "inbox/loop_closures";

// Queue sizes: keyframes are few and precious; stats only matter when fresh (scans: the
// Preprocessor's scan_queue_size).
constexpr int kKeyframeQueueSize = 100;
constexpr int kMessageQueueSize = 50;
/// Loop closures are small and may come in bursts (a teammate's backlog): none may be lost.
constexpr int kLoopClosureQueueSize = 1000;
constexpr int kLatestOnlyQueueSize = 1;
/// What the Bridge republishes from a teammate comes in bursts after an outage (its whole
/// backlog at once, e.g. a minute of 20 Hz control messages): a subscriber in another process
/// must not lose it from the publisher's queue.
constexpr int kInboxQueueSize = 2000;

}  // namespace ccir_mapping::topics
