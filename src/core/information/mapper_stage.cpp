#include "ccir_mapping/core/information/mapper_stage.h"

#include <malloc.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>

namespace ccir_mapping::core::information {

MapperStage::MapperStage(std::string robot, const MapperParams& params, Hooks hooks)
    : robot_(std::move(robot)),
      params_(params),
      hooks_(std::move(hooks)),
      map_(std::make_shared<SharedMap>(std::make_unique<OccupancyMap>(params))),
      keyframes_(params) {}

MapperStage::MapperStage(std::string robot, const MapperParams& params)
    : MapperStage(std::move(robot), params, Hooks{}) {}

MapperStage::~MapperStage() {
  if (rebuild_thread_.joinable()) rebuild_thread_.join();
}

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

// Holds mutex_: a rebuild swaps its map in under it, so a scan lands in the old map before the
// swap and is kept for the new one, or in the new one after it.
void MapperStage::insert(const std::vector<PlacedScan>& scans) {
  if (scans.empty()) return;
  hooks_.run("insert", [&] {
    map_->write([&](OccupancyMap& map) {
      for (const auto& scan : scans) map.insert(*scan.cloud, scan.map_from_sensor);
    });
  });
  if (rebuilding_)
    placed_during_rebuild_.insert(placed_during_rebuild_.end(), scans.begin(), scans.end());
}

bool MapperStage::rebuildIfDue(double now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (busy_) return false;
  const bool rebuild = keyframes_.rebuildDue() &&
                       (last_rebuild_scans_ == 0 ||
                        now_s - last_rebuild_s_ >= params_.rebuild_wait_s_per_scan *
                                                       static_cast<double>(last_rebuild_scans_));
  if (!rebuild && !keyframes_.settleDue()) return false;
  if (rebuild_thread_.joinable()) rebuild_thread_.join();
  busy_ = true;
  rebuilding_ = rebuild;
  auto settled = keyframes_.settle();
  std::vector<PlacedScan> scans;
  if (rebuild) {
    scans = keyframes_.placeAll();
    last_rebuild_s_ = now_s;
    last_rebuild_scans_ = scans.size();
  }
  rebuild_thread_ =
      std::thread([this, rebuild, settled = std::move(settled), scans = std::move(scans)] {
        const auto start = std::chrono::steady_clock::now();
        // Only this thread touches base_, and one runs at a time.
        auto fresh = base_ ? std::make_unique<OccupancyMap>(params_, *base_)
                           : std::make_unique<OccupancyMap>(params_);
        hooks_.run("rebuild", [&] {
          for (const auto& scan : settled) fresh->insert(*scan.cloud, scan.map_from_sensor);
          if (!settled.empty()) base_ = fresh->snapshot();
          for (const auto& scan : scans) fresh->insert(*scan.cloud, scan.map_from_sensor);
        });
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (rebuild) {
            for (const auto& scan : placed_during_rebuild_)
              fresh->insert(*scan.cloud, scan.map_from_sensor);
            placed_during_rebuild_.clear();
            map_->replace(std::move(fresh));
            ++rebuilds_;
          }
          busy_ = rebuilding_ = false;
        }
        rebuild_done_.notify_all();
        // The map that went held millions of small nodes; glibc keeps their pages unless
        // asked, and a resident size that grows with every rebuild looks like a leak.
        malloc_trim(0);
        if (rebuild && hooks_.rebuilt) {
          hooks_.rebuilt(
              scans.size(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
      });
  return rebuild;
}

void MapperStage::waitForRebuild() {
  std::unique_lock<std::mutex> lock(mutex_);
  rebuild_done_.wait(lock, [this] { return !busy_; });
}

std::string MapperStage::save(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create " + dir + ": " + error.message());
  const std::string path = dir + "/map.bt";
  waitForRebuild();
  // Written aside and renamed over the last save: a crash mid-save leaves a whole map to resume.
  const std::string aside = path + ".new";
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
  auto saved = std::make_unique<OccupancyMap>(params_);
  saved->load(path);
  std::lock_guard<std::mutex> lock(mutex_);
  if (busy_) throw std::logic_error("MapperStage::resume during a rebuild");
  base_ = saved->snapshot();
  map_->replace(std::move(saved));
  return true;
}

MapperStage::Stats MapperStage::stats() const {
  Stats stats;
  map_->read([&](const OccupancyMap& map) {
    stats.entropy_bits = map.boxEntropyBits();
    stats.known_volume_m3 = map.boxKnownVolumeM3();
    return 0;
  });
  std::lock_guard<std::mutex> lock(mutex_);
  stats.keyframes = keyframes_.ownKeyframes();
  stats.peer_scans = keyframes_.peerScans();
  stats.pending_peer_scans = keyframes_.pendingPeerScans();
  stats.settled_scans = keyframes_.settledScans();
  stats.rebuilds = rebuilds_;
  return stats;
}

}  // namespace ccir_mapping::core::information
