// What a robot's occupancy map is made of, and where each part goes: its own keyframes at their
// optimised poses; teammates' scans at the poses the team graph gives them, or (not in the graph,
// or not yet) with the team transform once it is known. Placed scans are grouped into submaps of
// submap_scans consecutive scans of one robot (SubmapSet holds their evidence); when poses move,
// takeMoves() says which submaps to move as a block (their first scan moved) and which to
// integrate again (a scan moved relative to the first), instead of rebuilding the map.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/information/submap_set.h"

namespace ccir_mapping::core::information {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// A scan, where its sensor is in the map frame, and the submap it goes into.
struct PlacedScan {
  std::shared_ptr<const Cloud> cloud;  // sensor frame
  Pose3 map_from_sensor = Pose3::Identity();
  SubmapId submap = 0;
};

class KeyframeMap {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit KeyframeMap(const MapperParams& params);

  /// An own keyframe with its odometry pose: placed with the latest optimised correction.
  PlacedScan addOwn(Stamp stamp, std::shared_ptr<const Cloud> cloud, const Pose3& odom_pose);
  /// A teammate's keyframe `id` with its pose in the teammate's frame: placed now if the
  /// teammate's frame is known (returned), else kept until it is. One already held is not
  /// added again (see holdsPeer).
  std::vector<PlacedScan> addPeer(const std::string& robot, KeyframeId id,
                                  std::shared_ptr<const Cloud> cloud, const Pose3& peer_pose);
  bool holdsPeer(const std::string& robot, KeyframeId id) const;
  /// The teammate's frame in the map frame: returns its waiting scans, now placed.
  std::vector<PlacedScan> setTeamTransform(const std::string& robot, const Pose3& map_from_peer);
  /// The map poses the team graph gives the teammate's keyframes (kept for scans that arrive
  /// later): they win over the team transform. Returns waiting scans now placed.
  std::vector<PlacedScan> setPeerPoses(const std::string& robot,
                                       const std::vector<std::pair<KeyframeId, Pose3>>& poses);
  /// Optimised sensor poses of own keyframes, by stamp (the Backend's trajectory).
  void setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses);

  /// A submap to move to `delta` (Submap::delta), or, when `scans` is not empty, to integrate
  /// again from its scans at their current poses (delta identity).
  struct Move {
    SubmapId id = 0;
    Pose3 delta = Pose3::Identity();
    std::vector<PlacedScan> scans;
  };
  /// The submaps, settled ones aside, whose first scan moved beyond the reanchor thresholds
  /// since they were last placed (moved), or one of whose scans moved beyond them relative to
  /// the first (integrated again); from now on they are where they are. A submap that moves
  /// takes no more scans.
  std::vector<Move> takeMoves();
  /// The submaps that took their last scan since the last call (full, or moved).
  std::vector<SubmapId> takeClosed();
  /// Once more than 1.25 submap_window_scans placed scans are in submaps not settled, settles
  /// the oldest closed submaps down to the window, releasing their clouds; returns them.
  std::vector<SubmapId> settle();

  /// Own keyframes and placed teammates' scans.
  std::size_t ownKeyframes() const { return own_.size(); }
  std::size_t peerScans() const { return placed_peers_; }
  std::size_t pendingPeerScans() const;
  std::size_t submaps() const { return submaps_.size(); }
  /// Placed scans in settled submaps.
  std::size_t settledScans() const { return settled_; }

 private:
  struct Own {
    std::shared_ptr<const Cloud> cloud;
    Pose3 odom_pose;
    Pose3 map_pose;  // best known
  };
  struct Peer {
    std::shared_ptr<const Cloud> cloud;
    Pose3 peer_pose;
    bool placed = false;
  };
  struct Teammate {
    std::map<KeyframeId, Peer> scans;
    bool known = false;
    Pose3 map_from_peer = Pose3::Identity();
    std::map<KeyframeId, Pose3> graph_poses;
  };
  /// A submap: its scans (own stamps, or a teammate's ids) in the order placed, and where they
  /// were when its evidence was integrated.
  struct Group {
    std::string robot;  // empty: own keyframes
    std::vector<std::int64_t> scans;
    Pose3 anchor;                     // the first scan's pose then
    std::vector<Pose3> relative;      // anchor^-1 * each scan's pose then
    Pose3 delta = Pose3::Identity();  // where the evidence is now
    bool open = true;
    bool settled = false;
  };

  bool moved(const Pose3& a, const Pose3& b) const;
  /// Where a teammate's scan goes now, if anywhere.
  static std::optional<Pose3> poseOf(const Teammate& t, KeyframeId id, const Peer& scan);
  Pose3 poseOf(const Group& s, std::size_t i) const;
  std::shared_ptr<const Cloud>& cloudOf(const Group& s, std::size_t i);
  /// The submap the robot's next placed scan goes into (a new one when its open one is full).
  SubmapId place(const std::string& robot, std::int64_t scan, const Pose3& pose);
  void close(SubmapId id, Group& s);
  /// Places the teammate's waiting scans that can be.
  std::vector<PlacedScan> update(const std::string& robot, Teammate& t);

  MapperParams params_;
  std::map<Stamp, Own> own_;
  std::map<std::string, Teammate> teammates_;
  std::map<SubmapId, Group> submaps_;
  std::map<std::string, SubmapId> open_;  // by robot ("" own)
  std::vector<SubmapId> closed_;          // since takeClosed()
  SubmapId next_id_ = 1;                  // 0: a map read from a file
  /// map_from_odom of the latest optimised keyframe: places new keyframes.
  Pose3 correction_ = Pose3::Identity();
  std::size_t placed_peers_ = 0;
  std::size_t live_ = 0;  // placed scans in submaps not settled
  std::size_t settled_ = 0;
};

}  // namespace ccir_mapping::core::information
