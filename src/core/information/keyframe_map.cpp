#include "ccir_mapping/core/information/keyframe_map.h"

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::information {

KeyframeMap::KeyframeMap(const MapperParams& params) : params_(validated(params)) {}

bool KeyframeMap::moved(const Pose3& a, const Pose3& b) const {
  const Pose3 delta = a.inverse() * b;
  return delta.translation().norm() > params_.reanchor_shift_m ||
         Eigen::AngleAxisd(delta.linear()).angle() > params_.reanchor_rotation_deg * M_PI / 180;
}

std::optional<Pose3> KeyframeMap::poseOf(const Teammate& t, KeyframeId id, const Peer& scan) {
  if (const auto graph = t.graph_poses.find(id); graph != t.graph_poses.end()) {
    return graph->second;
  }
  if (t.known) return t.map_from_peer * scan.peer_pose;
  return std::nullopt;
}

// A placed scan always has a pose: the graph's poses and the team transform are never taken back.
Pose3 KeyframeMap::poseOf(const Group& s, std::size_t i) const {
  if (s.robot.empty()) return own_.at(s.scans[i]).map_pose;
  const Teammate& t = teammates_.at(s.robot);
  const auto id = static_cast<KeyframeId>(s.scans[i]);
  return *poseOf(t, id, t.scans.at(id));
}

std::shared_ptr<const Cloud>& KeyframeMap::cloudOf(const Group& s, std::size_t i) {
  if (s.robot.empty()) return own_.at(s.scans[i]).cloud;
  return teammates_.at(s.robot).scans.at(static_cast<KeyframeId>(s.scans[i])).cloud;
}

SubmapId KeyframeMap::place(const std::string& robot, std::int64_t scan, const Pose3& pose) {
  SubmapId& id = open_[robot];
  auto it = submaps_.find(id);
  if (it == submaps_.end() || !it->second.open) {
    id = next_id_++;
    it = submaps_.emplace(id, Group{robot, {}, pose, {}}).first;
  }
  Group& s = it->second;
  s.scans.push_back(scan);
  s.relative.push_back(s.anchor.inverse() * pose);
  ++live_;
  if (s.scans.size() >= static_cast<std::size_t>(params_.submap_scans)) close(id, s);
  return id;
}

void KeyframeMap::close(SubmapId id, Group& s) {
  if (!s.open) return;
  s.open = false;
  closed_.push_back(id);
}

PlacedScan KeyframeMap::addOwn(Stamp stamp, std::shared_ptr<const Cloud> cloud,
                               const Pose3& odom_pose) {
  const Pose3 map_pose = correction_ * odom_pose;
  own_[stamp] = {cloud, odom_pose, map_pose};
  return {std::move(cloud), map_pose, place("", stamp, map_pose)};
}

std::vector<PlacedScan> KeyframeMap::update(const std::string& robot, Teammate& t) {
  std::vector<PlacedScan> placed;
  for (auto& [id, scan] : t.scans) {
    if (scan.placed) continue;
    const auto pose = poseOf(t, id, scan);
    if (!pose) continue;
    scan.placed = true;
    ++placed_peers_;
    placed.push_back({scan.cloud, *pose, place(robot, static_cast<std::int64_t>(id), *pose)});
  }
  return placed;
}

std::vector<PlacedScan> KeyframeMap::addPeer(const std::string& robot, KeyframeId id,
                                             std::shared_ptr<const Cloud> cloud,
                                             const Pose3& peer_pose) {
  Teammate& t = teammates_[robot];
  if (!t.scans.emplace(id, Peer{std::move(cloud), peer_pose}).second) return {};
  return update(robot, t);
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
  return update(robot, t);
}

std::vector<PlacedScan> KeyframeMap::setPeerPoses(
    const std::string& robot, const std::vector<std::pair<KeyframeId, Pose3>>& poses) {
  Teammate& t = teammates_[robot];
  for (const auto& [id, pose] : poses) t.graph_poses[id] = pose;
  return update(robot, t);
}

void KeyframeMap::setOptimizedPoses(const std::vector<std::pair<Stamp, Pose3>>& poses) {
  for (const auto& [stamp, pose] : poses) {
    const auto it = own_.find(stamp);
    if (it == own_.end()) continue;
    it->second.map_pose = pose;
    correction_ = pose * it->second.odom_pose.inverse();
  }
}

std::vector<KeyframeMap::Move> KeyframeMap::takeMoves() {
  std::vector<Move> moves;
  for (auto& [id, s] : submaps_) {
    if (s.settled) continue;
    const Pose3 anchor = poseOf(s, 0);
    bool reintegrate = false;
    std::vector<Pose3> relative(s.scans.size());
    for (std::size_t i = 0; i < s.scans.size(); ++i) {
      relative[i] = anchor.inverse() * poseOf(s, i);
      reintegrate |= moved(s.relative[i], relative[i]);
    }
    if (reintegrate) {
      Move move{id, Pose3::Identity(), {}};
      for (std::size_t i = 0; i < s.scans.size(); ++i) {
        move.scans.push_back({cloudOf(s, i), anchor * relative[i], id});
      }
      s.anchor = anchor;
      s.relative = std::move(relative);
      s.delta = Pose3::Identity();
      moves.push_back(std::move(move));
    } else if (moved(s.delta * s.anchor, anchor)) {
      s.delta = anchor * s.anchor.inverse();
      moves.push_back({id, s.delta, {}});
    } else {
      continue;
    }
    close(id, s);
  }
  return moves;
}

std::vector<SubmapId> KeyframeMap::takeClosed() { return std::exchange(closed_, {}); }

std::vector<SubmapId> KeyframeMap::settle() {
  const auto window = static_cast<std::size_t>(params_.submap_window_scans);
  if (window == 0 || live_ <= window + window / 4) return {};
  std::vector<SubmapId> settled;
  for (auto& [id, s] : submaps_) {
    if (live_ <= window) break;
    if (s.open || s.settled) continue;
    for (std::size_t i = 0; i < s.scans.size(); ++i) cloudOf(s, i).reset();
    s.settled = true;
    live_ -= s.scans.size();
    settled_ += s.scans.size();
    settled.push_back(id);
  }
  return settled;
}

std::size_t KeyframeMap::pendingPeerScans() const {
  std::size_t n = 0;
  for (const auto& [robot, t] : teammates_) {
    for (const auto& [id, scan] : t.scans) n += !scan.placed;
  }
  return n;
}

}  // namespace ccir_mapping::core::information
