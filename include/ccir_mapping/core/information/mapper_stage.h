// The Mapper's stage: what a robot's occupancy map is made of (KeyframeMap), its submaps
// (SubmapSet) and the map itself (a SharedMap, which the Broker reads in process). A placed scan
// is integrated at once, into its submap and the map. When the optimised poses or a team
// transform move, followPoses() moves the submaps whose scans moved as blocks, integrates again
// only those whose scans moved relative to each other, and recomputes the map only where they
// were and are: its cost follows what moved, not the mission's length.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/information/keyframe_map.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/information/shared_map.h"
#include "ccir_mapping/core/information/submap_set.h"

namespace ccir_mapping::core::information {

class MapperStage {
 public:
  /// What the map holds, for MapStats.
  struct Stats {
    double entropy_bits = 0.0;
    double known_volume_m3 = 0.0;
    std::size_t keyframes = 0;
    std::size_t peer_scans = 0;
    std::size_t pending_peer_scans = 0;
    /// Live submaps; of keyframes and peer_scans, those settled (submap_window_scans).
    std::size_t submaps = 0;
    std::size_t settled_scans = 0;
    /// Submaps moved as blocks, and integrated again, since the start.
    std::uint64_t submap_moves = 0;
    std::uint64_t reintegrations = 0;
    /// Memory of the map's octree (estimated from its node count) and of the submaps' evidence,
    /// MB.
    double map_mb = 0.0;
    double submap_mb = 0.0;
  };
  /// Runs a piece of map work ("insert", "reanchor") and lets the caller measure it.
  struct Hooks {
    std::function<void(const char* stage, const std::function<void()>& work)> run =
        [](const char*, const std::function<void()>& work) { work(); };
  };

  /// The map of robot `robot`. Throws std::invalid_argument when params.validate() reports
  /// errors.
  MapperStage(std::string robot, const MapperParams& params, Hooks hooks);
  MapperStage(std::string robot, const MapperParams& params);

  const std::shared_ptr<SharedMap>& map() const { return map_; }

  /// An own keyframe (sensor frame) with its odometry pose.
  void addOwn(Stamp stamp, std::shared_ptr<const Cloud> cloud, const Pose3& odom_pose);
  /// A teammate's scan with its pose in the teammate's frame, placed once the team transform is
  /// known; otherwise why not (nothing changes): the map holds it already, or it is this
  /// robot's own.
  std::optional<std::string> addPeer(const std::string& robot, KeyframeId id,
                                     std::shared_ptr<const Cloud> cloud, const Pose3& peer_pose);
  /// A teammate's map frame in this robot's (a transform to this robot itself is ignored).
  void setTeamTransform(const std::string& robot, const Pose3& map_from_peer);
  /// Where the team graph puts a teammate's keyframes (KeyframeMap::setPeerPoses; poses for
  /// this robot itself are ignored).
  void setPeerPoses(const std::string& robot,
                    const std::vector<std::pair<KeyframeId, Pose3>>& poses);
  void setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses);

  /// Brings the map to the poses set since the last call (KeyframeMap::takeMoves) and settles
  /// the submaps beyond the window, unless the wait after the last one
  /// (reanchor_wait_s_per_mvoxel_visited) runs until after `now_s` (seconds on the clock the cost
  /// is paid in: the wall clock of a robot, simulated time of a simulated one); returns the submaps
  /// moved or integrated again.
  std::size_t followPoses(double now_s);
  /// Writes the map to DIR/map.bt (OctoMap binary), creating DIR, and returns the file's path.
  /// Throws std::runtime_error naming what it could not write.
  std::string save(const std::string& dir);
  /// Continues the map save() left in DIR/map.bt, before any scan is added: it starts the
  /// settled part of the map, beneath this run's scans. False when there is no such file (nothing
  /// to resume); throws std::runtime_error naming it when it cannot be read
  /// (OccupancyMap::load), std::logic_error once scans were added.
  bool resume(const std::string& dir);
  Stats stats() const;

 private:
  void insert(const std::vector<PlacedScan>& scans);

  const std::string robot_;
  const Hooks hooks_;
  std::shared_ptr<SharedMap> map_;
  mutable std::mutex mutex_;  // guards what follows; only this stage writes the map
  KeyframeMap keyframes_;
  SubmapSet submaps_;
  const double wait_s_per_mvoxel_visited_;
  double next_follow_s_ = -std::numeric_limits<double>::infinity();
  std::uint64_t submap_moves_ = 0;
  std::uint64_t reintegrations_ = 0;
};

}  // namespace ccir_mapping::core::information
