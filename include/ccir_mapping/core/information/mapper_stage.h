// The Mapper's stage: what a robot's occupancy map is made of (KeyframeMap) and the map itself
// (a SharedMap, which the Broker reads in process). Placed scans are integrated at once. When the
// optimised poses or a team transform have moved enough, rebuildIfDue() builds a fresh map at the
// current poses on a thread of its own and swaps it in; scans placed meanwhile go into both maps,
// so none is lost. With a rebuild window (MapperParams::rebuild_window_scans) a rebuild starts
// from a compact base map of the settled older scans, so its cost and the clouds held stay
// bounded however long the mission.
#pragma once

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ccir_mapping/core/information/keyframe_map.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/information/shared_map.h"

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
    /// Of keyframes and peer_scans, those settled into the base map (rebuild_window_scans).
    std::size_t settled_scans = 0;
    std::uint32_t rebuilds = 0;
  };
  /// Runs a piece of map work (integrating scans, a rebuild) and lets the caller measure it;
  /// `rebuilt` reports each finished rebuild (its scans and wall seconds) on the rebuild thread.
  struct Hooks {
    std::function<void(const char* stage, const std::function<void()>& work)> run =
        [](const char*, const std::function<void()>& work) { work(); };
    std::function<void(std::size_t scans, double seconds)> rebuilt;
  };

  /// The map of robot `robot`. Throws std::invalid_argument when params.validate() reports
  /// errors.
  MapperStage(std::string robot, const MapperParams& params, Hooks hooks);
  MapperStage(std::string robot, const MapperParams& params);
  /// Waits for a rebuild under way.
  ~MapperStage();
  MapperStage(const MapperStage&) = delete;
  MapperStage& operator=(const MapperStage&) = delete;

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

  /// Starts a rebuild when one is due, none is under way and rebuild_wait_s_per_scan times the
  /// scans of the last rebuild have passed since it started (`now_s`: seconds on the clock its
  /// cost is paid in: the wall clock of a robot, simulated time of a simulated one); true when
  /// it started. Settles the scans beyond the rebuild window into the base map, on the same
  /// thread, with the rebuild or on its own once due (KeyframeMap::settleDue).
  bool rebuildIfDue(double now_s);
  /// Returns once no rebuild or settling is under way.
  void waitForRebuild();
  /// Writes the map as it is once a rebuild under way is done to DIR/map.bt (OctoMap binary),
  /// creating DIR, and returns the file's path. Throws std::runtime_error naming what it could
  /// not write.
  std::string save(const std::string& dir);
  /// Continues the map save() left in DIR/map.bt, before any scan is added: it becomes what
  /// rebuilds start from, so it stays beneath this run's scans (at the poses it was built at).
  /// False when there is no such file (nothing to resume); throws std::runtime_error naming it
  /// when it cannot be read (OccupancyMap::load).
  bool resume(const std::string& dir);
  Stats stats() const;

 private:
  void insert(const std::vector<PlacedScan>& scans);

  const std::string robot_;
  const MapperParams params_;
  const Hooks hooks_;
  std::shared_ptr<SharedMap> map_;
  mutable std::mutex mutex_;  // guards what follows
  KeyframeMap keyframes_;
  bool busy_ = false;        // the rebuild thread runs
  bool rebuilding_ = false;  // and will swap in a rebuilt map
  std::condition_variable rebuild_done_;
  std::vector<PlacedScan> placed_during_rebuild_;
  std::uint32_t rebuilds_ = 0;
  double last_rebuild_s_ = 0.0;
  std::size_t last_rebuild_scans_ = 0;  // 0 before the first rebuild
  /// What rebuilds start from: the settled scans (only the rebuild thread touches it).
  std::optional<OccupancyMap::Snapshot> base_;
  std::thread rebuild_thread_;
};

}  // namespace ccir_mapping::core::information
