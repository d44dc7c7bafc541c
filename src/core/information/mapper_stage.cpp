#include "ccir_mapping/core/information/mapper_stage.h"

#include <malloc.h>

#include <filesystem>
#include <stdexcept>

namespace ccir_mapping::core::information {

MapperStage::MapperStage(std::string robot, const MapperParams& params, Hooks hooks)
    : robot_(std::move(robot)),
      hooks_(std::move(hooks)),
      map_(std::make_shared<SharedMap>(std::make_unique<OccupancyMap>(params))),
      keyframes_(params),
      // The map's grid is never replaced, so the reference stays good.
      submaps_(*map_->read([](const OccupancyMap& map) { return &map.grid(); })),
      wait_s_per_mvoxel_visited_(params.reanchor_wait_s_per_mvoxel_visited) {}

MapperStage::MapperStage(std::string robot, const MapperParams& params)
    : MapperStage(std::move(robot), params, Hooks{}) {}

void MapperStage::addOwn(Stamp stamp, std::shared_ptr<const Cloud> cloud, const Pose3& odom_pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  insert({keyframes_.addOwn(stamp, std::move(cloud), odom_pose)});
}

std::optional<std::string> MapperStage::addPeer(const std::string& robot, KeyframeId id,
                                                std::shared_ptr<const Cloud> cloud,
                                                const Pose3& peer_pose) {
  if (robot == robot_) return "it is this robot's own";
  std::lock_guard<std::mutex> lock(mutex_);
  if (keyframes_.holdsPeer(robot, id)) return "it is in the map already";
  insert(keyframes_.addPeer(robot, id, std::move(cloud), peer_pose));
  return std::nullopt;
}

void MapperStage::setTeamTransform(const std::string& robot, const Pose3& map_from_peer) {
  if (robot == robot_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  insert(keyframes_.setTeamTransform(robot, map_from_peer));
}

void MapperStage::setPeerPoses(const std::string& robot,
                               const std::vector<std::pair<KeyframeId, Pose3>>& poses) {
  if (robot == robot_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  insert(keyframes_.setPeerPoses(robot, poses));
}

void MapperStage::setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses) {
  std::lock_guard<std::mutex> lock(mutex_);
  keyframes_.setOptimizedPoses(poses);
}

// Holds mutex_. The map's keys and rays depend on its resolution only, so the update is
// computed under the shared lock and only applied under the exclusive one.
void MapperStage::insert(const std::vector<PlacedScan>& scans) {
  if (scans.empty()) return;
  hooks_.run("insert", [&] {
    for (const auto& scan : scans) {
      const ScanUpdate update = map_->read([&](const OccupancyMap& map) {
        return map.computeUpdate(*scan.cloud, scan.map_from_sensor);
      });
      map_->write([&](OccupancyMap& map) { map.insert(update); });
      submaps_.add(scan.submap, update);
    }
    for (const SubmapId id : keyframes_.takeClosed()) submaps_.close(id);
  });
}

std::size_t MapperStage::followPoses(double now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (now_s < next_follow_s_) return 0;
  std::size_t changed = 0;
  hooks_.run("reanchor", [&] {
    std::vector<SubmapSet::Change> changes;
    for (auto& move : keyframes_.takeMoves()) {
      SubmapSet::Change change{move.id, move.delta, std::nullopt};
      if (!move.scans.empty()) {
        change.updates.emplace();
        map_->read([&](const OccupancyMap& map) {
          for (const auto& scan : move.scans) {
            change.updates->push_back(map.computeUpdate(*scan.cloud, scan.map_from_sensor));
          }
          return 0;
        });
        ++reintegrations_;
      } else {
        ++submap_moves_;
      }
      changes.push_back(std::move(change));
    }
    changed = changes.size();
    for (const SubmapId id : keyframes_.takeClosed()) submaps_.close(id);
    if (!changes.empty()) {
      const auto voxels = submaps_.apply(changes);
      map_->write([&](OccupancyMap& map) { map.assign(voxels); });
      next_follow_s_ =
          now_s + wait_s_per_mvoxel_visited_ * static_cast<double>(submaps_.lastVisited()) / 1e6;
    }
    const auto settled = keyframes_.settle();
    for (const SubmapId id : settled) submaps_.settle(id);
    if (!settled.empty()) {
      // glibc keeps the pages of freed clouds and evidence unless asked: a resident size that
      // only grows looks like a leak.
      malloc_trim(0);
    }
  });
  return changed;
}

std::string MapperStage::save(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create " + dir + ": " + error.message());
  const std::string path = dir + "/map.bt";
  // Written aside and renamed over the last save: a crash mid-save leaves a whole map to resume.
  const std::string aside = path + ".new";
  std::lock_guard<std::mutex> lock(mutex_);
  if (!map_->write([&](OccupancyMap& map) { return map.save(aside); })) {
    throw std::runtime_error("cannot write " + path);
  }
  std::filesystem::rename(aside, path, error);
  if (error) throw std::runtime_error("cannot write " + path + ": " + error.message());
  return path;
}

bool MapperStage::resume(const std::string& dir) {
  const std::string path = dir + "/map.bt";
  if (!std::filesystem::exists(path)) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  if (keyframes_.ownKeyframes() + keyframes_.peerScans() + keyframes_.pendingPeerScans() > 0) {
    throw std::logic_error("MapperStage::resume after scans were added");
  }
  map_->write([&](OccupancyMap& map) {
    map.load(path);
    submaps_.addSettled(map.voxels());
  });
  return true;
}

MapperStage::Stats MapperStage::stats() const {
  Stats stats;
  map_->read([&](const OccupancyMap& map) {
    stats.entropy_bits = map.boxEntropyBits();
    stats.known_volume_m3 = map.boxKnownVolumeM3();
    stats.map_mb = static_cast<double>(map.voxels().bytes()) / 1e6;
    return 0;
  });
  std::lock_guard<std::mutex> lock(mutex_);
  stats.keyframes = keyframes_.ownKeyframes();
  stats.peer_scans = keyframes_.peerScans();
  stats.pending_peer_scans = keyframes_.pendingPeerScans();
  stats.submaps = submaps_.size();
  stats.settled_scans = keyframes_.settledScans();
  stats.submap_moves = submap_moves_;
  stats.reintegrations = reintegrations_;
  stats.submap_mb = static_cast<double>(submaps_.bytes()) / 1e6;
  return stats;
}

}  // namespace ccir_mapping::core::information
