#include "ccir_mapping/core/information/keyframe_map.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Geometry>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::information {

KeyframeMap::KeyframeMap(const MapperParams& params) : params_(validated(params)) {}

bool KeyframeMap::moved(const Pose3& a, const Pose3& b) const {
  const Pose3 delta = a.inverse() * b;
  return delta.translation().norm() > params_.rebuild_shift_m ||
         Eigen::AngleAxisd(delta.linear()).angle() > params_.rebuild_rotation_deg * M_PI / 180;
}

PlacedScan KeyframeMap::addOwn(Stamp stamp, std::shared_ptr<const Cloud> cloud,
                               const Pose3& odom_pose) {
  const Pose3 map_pose = correction_ * odom_pose;
  own_[stamp] = {cloud, odom_pose, map_pose, map_pose, ++placed_};
  return {std::move(cloud), map_pose};
}

std::optional<Pose3> KeyframeMap::poseOf(const Teammate& t, KeyframeId id, const Peer& scan) {
  if (const auto graph = t.graph_poses.find(id); graph != t.graph_poses.end()) {
    return graph->second;
  }
  if (t.known) return t.map_from_peer * scan.peer_pose;
  return std::nullopt;
}

std::vector<PlacedScan> KeyframeMap::update(Teammate& t) {
  std::vector<PlacedScan> placed;
  for (auto& [id, scan] : t.scans) {
    const auto pose = poseOf(t, id, scan);
    if (!pose) continue;
    if (scan.placed) {
      rebuild_due_ |= moved(scan.inserted_pose, *pose);
      continue;
    }
    scan.placed = true;
    scan.inserted_pose = *pose;
    scan.placed_order = ++placed_;
    placed.push_back({scan.cloud, *pose});
  }
  return placed;
}

std::vector<PlacedScan> KeyframeMap::addPeer(const std::string& robot, KeyframeId id,
                                             std::shared_ptr<const Cloud> cloud,
                                             const Pose3& peer_pose) {
  Teammate& t = teammates_[robot];
  if (t.settled.count(id) > 0) return {};
  const auto [it, added] = t.scans.emplace(id, Peer{std::move(cloud), peer_pose});
  if (!added) return {};
  const auto pose = poseOf(t, id, it->second);
  if (!pose) return {};
  it->second.placed = true;
  it->second.inserted_pose = *pose;
  it->second.placed_order = ++placed_;
  return {{it->second.cloud, *pose}};
}

bool KeyframeMap::holdsPeer(const std::string& robot, KeyframeId id) const {
  const auto t = teammates_.find(robot);
  return t != teammates_.end() &&
         (t->second.scans.count(id) > 0 || t->second.settled.count(id) > 0);
}

std::vector<PlacedScan> KeyframeMap::setTeamTransform(const std::string& robot,
                                                      const Pose3& map_from_peer) {
  Teammate& t = teammates_[robot];
  t.map_from_peer = map_from_peer;
  t.known = true;
  return update(t);
}

std::vector<PlacedScan> KeyframeMap::setPeerPoses(
    const std::string& robot, const std::vector<std::pair<KeyframeId, Pose3>>& poses) {
  Teammate& t = teammates_[robot];
  for (const auto& [id, pose] : poses) t.graph_poses[id] = pose;
  return update(t);
}

void KeyframeMap::setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses) {
  for (const auto& [stamp, pose] : poses) {
    const auto it = own_.find(stamp);
    if (it == own_.end()) continue;
    it->second.map_pose = pose;
    correction_ = pose * it->second.odom_pose.inverse();
    rebuild_due_ |= moved(it->second.inserted_pose, pose);
  }
}

std::vector<PlacedScan> KeyframeMap::placeAll() {
  std::vector<PlacedScan> placed;
  for (auto& [stamp, k] : own_) {
    k.inserted_pose = k.map_pose;
    placed.push_back({k.cloud, k.map_pose});
  }
  for (auto& [robot, t] : teammates_) {
    for (auto& [id, scan] : t.scans) {
      const auto pose = poseOf(t, id, scan);
      if (!pose) continue;
      if (!scan.placed) scan.placed_order = ++placed_;
      scan.placed = true;
      scan.inserted_pose = *pose;
      placed.push_back({scan.cloud, *pose});
    }
  }
  rebuild_due_ = false;
  return placed;
}

bool KeyframeMap::settleDue() const {
  const auto window = static_cast<std::size_t>(params_.rebuild_window_scans);
  const std::size_t held = own_.size() + peerScans() - settled_peer_;
  return window > 0 && held > window + window / 4;
}

std::vector<PlacedScan> KeyframeMap::settle() {
  const auto window = static_cast<std::size_t>(params_.rebuild_window_scans);
  // Placement order of every placed scan holding its cloud, and how to settle it.
  std::vector<std::pair<std::uint64_t, std::function<PlacedScan()>>> held;
  for (auto& [stamp, k] : own_) {
    held.emplace_back(k.placed_order, [this, stamp = stamp] {
      const auto it = own_.find(stamp);
      PlacedScan scan{it->second.cloud, it->second.map_pose};
      own_.erase(it);
      ++settled_own_;
      return scan;
    });
  }
  for (auto& [robot, t] : teammates_) {
    for (auto& [id, scan] : t.scans) {
      if (!scan.placed) continue;
      held.emplace_back(scan.placed_order, [this, &t = t, id = id] {
        const auto it = t.scans.find(id);
        PlacedScan placed{it->second.cloud, *poseOf(t, id, it->second)};
        t.scans.erase(it);
        t.settled.insert(id);
        ++settled_peer_;
        return placed;
      });
    }
  }
  if (window == 0 || held.size() <= window) return {};
  std::sort(held.begin(), held.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<PlacedScan> settled;
  for (std::size_t i = 0; i + window < held.size(); ++i) settled.push_back(held[i].second());
  return settled;
}

std::size_t KeyframeMap::peerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) {
    for (const auto& [id, scan] : t.scans) n += scan.placed;
  }
  return n + settled_peer_;
}

std::size_t KeyframeMap::pendingPeerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) {
    for (const auto& [id, scan] : t.scans) n += !scan.placed;
  }
  return n;
}

}  // namespace ccir_mapping::core::information
