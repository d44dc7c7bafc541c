// What a robot's occupancy map is made of, and where each part goes: its own keyframes at their
// optimised poses; teammates' scans at the poses the team graph gives them, or (not in the graph,
// or not yet) with the team transform once it is known. The map follows the optimised poses by
// rebuilding: when an inserted scan's pose has moved more than the rebuild thresholds,
// rebuildDue() turns true and the caller builds a fresh OccupancyMap from placeAll() (OctoMap
// cannot move what it integrated).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/mapper_params.h"

namespace ccir_mapping::core::information {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// A scan and where its sensor is in the map frame.
struct PlacedScan {
  std::shared_ptr<const Cloud> cloud;  // sensor frame
  Pose3 map_from_sensor = Pose3::Identity();
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
  /// The teammate's frame in the map frame: returns its waiting scans, now placed. A placed scan
  /// that moves beyond the thresholds makes a rebuild due.
  std::vector<PlacedScan> setTeamTransform(const std::string& robot, const Pose3& map_from_peer);
  /// The map poses the team graph gives the teammate's keyframes (kept for scans that arrive
  /// later): they win over the team transform. Returns waiting scans now placed; a placed scan
  /// that moves beyond the thresholds makes a rebuild due.
  std::vector<PlacedScan> setPeerPoses(const std::string& robot,
                                       const std::vector<std::pair<KeyframeId, Pose3>>& poses);
  /// Optimised sensor poses of own keyframes, by stamp (the Backend's trajectory).
  void setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses);

  bool rebuildDue() const { return rebuild_due_; }
  /// Every placeable scan at the current poses, settled ones aside; clears rebuildDue().
  std::vector<PlacedScan> placeAll();

  /// More than 1.25 rebuild_window_scans placed scans hold their clouds.
  bool settleDue() const;
  /// The placed scans beyond the newest rebuild_window_scans, oldest first, at their current
  /// poses: from now on they are settled (never placed again; a teammate's is still held).
  std::vector<PlacedScan> settle();

  /// Own keyframes and placed teammates' scans, settled ones included.
  std::size_t ownKeyframes() const { return own_.size() + settled_own_; }
  std::size_t peerScans() const;
  std::size_t pendingPeerScans() const;
  std::size_t settledScans() const { return settled_own_ + settled_peer_; }

 private:
  struct Own {
    std::shared_ptr<const Cloud> cloud;
    Pose3 odom_pose;
    /// Best known pose, and the pose it was inserted with.
    Pose3 map_pose;
    Pose3 inserted_pose;
    std::uint64_t placed_order = 0;
  };
  struct Peer {
    std::shared_ptr<const Cloud> cloud;
    Pose3 peer_pose;
    bool placed = false;
    Pose3 inserted_pose = Pose3::Identity();
    std::uint64_t placed_order = 0;
  };
  struct Teammate {
    std::map<KeyframeId, Peer> scans;
    std::set<KeyframeId> settled;
    bool known = false;
    Pose3 map_from_peer = Pose3::Identity();
    std::map<KeyframeId, Pose3> graph_poses;
  };

  bool moved(const Pose3& a, const Pose3& b) const;
  /// Where a teammate's scan goes now, if anywhere.
  static std::optional<Pose3> poseOf(const Teammate& t, KeyframeId id, const Peer& scan);
  /// Places the teammate's waiting scans that can be (returned) and marks a rebuild due when a
  /// placed one moved.
  std::vector<PlacedScan> update(Teammate& t);

  MapperParams params_;
  std::map<Stamp, Own> own_;
  std::map<std::string, Teammate> teammates_;
  /// map_from_odom of the latest optimised keyframe: places new keyframes.
  Pose3 correction_ = Pose3::Identity();
  bool rebuild_due_ = false;
  /// Counts placements: orders the scans for the rebuild window.
  std::uint64_t placed_ = 0;
  std::size_t settled_own_ = 0;
  std::size_t settled_peer_ = 0;
};

}  // namespace ccir_mapping::core::information
