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

std::vector<PlacedScan> KeyframeMap::addPeer(const std::string& robot, KeyframeId id,
                                             std::shared_ptr<const Cloud> cloud,
                                             const Pose3& peer_pose) {
  Teammate& t = teammates_[robot];
  if (!t.scans.emplace(id, Peer{cloud, peer_pose}).second || !t.known) return {};
  return {{std::move(cloud), t.map_from_peer * peer_pose}};
}

bool KeyframeMap::holdsPeer(const std::string& robot, KeyframeId id) const {
  const auto t = teammates_.find(robot);
  return t != teammates_.end() && t->second.scans.count(id) > 0;
}

std::vector<PlacedScan> KeyframeMap::setTeamTransform(const std::string& robot,
                                                      const Pose3& map_from_peer) {
  Teammate& t = teammates_[robot];
  const bool first = !t.known;
  t.map_from_peer = map_from_peer;
  t.known = true;
  if (!first) {
    rebuild_due_ |= moved(t.inserted_transform, map_from_peer);
    return {};
  }
  t.inserted_transform = map_from_peer;
  std::vector<PlacedScan> placed;
  for (const auto& [id, s] : t.scans) placed.push_back({s.cloud, map_from_peer * s.peer_pose});
  return placed;
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
    if (!t.known) continue;
    t.inserted_transform = t.map_from_peer;
    for (const auto& [id, s] : t.scans) placed.push_back({s.cloud, t.map_from_peer * s.peer_pose});
  }
  rebuild_due_ = false;
  return placed;
}

std::size_t KeyframeMap::peerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) n += t.known ? t.scans.size() : 0;
  return n;
}

std::size_t KeyframeMap::pendingPeerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) n += t.known ? 0 : t.scans.size();
  return n;
}

}  // namespace ccir_mapping::core::information
