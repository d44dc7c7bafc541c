#include "ccir_mapping/core/information/keyframe_map.h"

#include <cmath>

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
  own_[stamp] = {cloud, odom_pose, map_pose, map_pose};
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
    placed.push_back({scan.cloud, *pose});
  }
  return placed;
}

std::vector<PlacedScan> KeyframeMap::addPeer(const std::string& robot, KeyframeId id,
                                             std::shared_ptr<const Cloud> cloud,
                                             const Pose3& peer_pose) {
  Teammate& t = teammates_[robot];
  const auto [it, added] = t.scans.emplace(id, Peer{std::move(cloud), peer_pose});
  if (!added) return {};
  const auto pose = poseOf(t, id, it->second);
  if (!pose) return {};
  it->second.placed = true;
  it->second.inserted_pose = *pose;
  return {{it->second.cloud, *pose}};
}

bool KeyframeMap::holdsPeer(const std::string& robot, KeyframeId id) const {
  const auto t = teammates_.find(robot);
  return t != teammates_.end() && t->second.scans.count(id) > 0;
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
      scan.placed = true;
      scan.inserted_pose = *pose;
      placed.push_back({scan.cloud, *pose});
    }
  }
  rebuild_due_ = false;
  return placed;
}

std::size_t KeyframeMap::peerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) {
    for (const auto& [id, scan] : t.scans) n += scan.placed;
  }
  return n;
}

std::size_t KeyframeMap::pendingPeerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) {
    for (const auto& [id, scan] : t.scans) n += !scan.placed;
  }
  return n;
}

}  // namespace ccir_mapping::core::information
