#include "ccir_mapping/core/information/submap.h"

#include <algorithm>
#include <cmath>

#include "ccir_mapping/core/information/key_codes.h"

namespace ccir_mapping::core::information {

Submap::Model Submap::Model::of(const octomap::OcTree& tree) {
  return {tree.getProbHitLog(), tree.getProbMissLog(), tree.getClampingThresMinLog(),
          tree.getClampingThresMaxLog()};
}

void Submap::grow(const octomap::OcTreeKey& key) {
  for (int a = 0; a < 3; ++a) {
    min_[a] = std::min(min_[a], key[a]);
    max_[a] = std::max(max_[a], key[a]);
  }
}

void Submap::add(const ScanUpdate& update) {
  if (closed_) return;
  for (const auto& key : update.free) {
    added_.push_back(packKey(key));
    grow(key);
  }
  for (const auto& key : update.occupied) {
    added_.push_back(packKey(key) | kHit);
    grow(key);
  }
  if (added_.size() >= voxels_.size()) fold();
}

template <class Step>
void Submap::merge(std::vector<std::uint64_t>& codes, Step step) {
  constexpr std::uint64_t kKey = kHit - 1;
  constexpr std::uint64_t kNone = ~std::uint64_t{0};
  std::vector<Voxel> merged;
  merged.reserve(voxels_.size() + codes.size() / 2);
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < voxels_.size() || j < codes.size()) {
    const std::uint64_t old_key = i < voxels_.size() ? packKey(voxels_[i].key) : kNone;
    const std::uint64_t new_key = j < codes.size() ? (codes[j] & kKey) : kNone;
    if (old_key < new_key) {
      merged.push_back(voxels_[i++]);
      continue;
    }
    float log_odds =
        old_key == new_key ? static_cast<float>(voxels_[i++].log_odds_mils) * 1e-3F : 0.0F;
    for (; j < codes.size() && (codes[j] & kKey) == new_key; ++j) {
      log_odds = std::clamp(step(log_odds, codes[j]), model_.min, model_.max);
    }
    merged.push_back({unpackKey(new_key), static_cast<std::int16_t>(std::lround(log_odds * 1e3F))});
  }
  merged.shrink_to_fit();
  voxels_.swap(merged);
}

void Submap::fold() {
  if (added_.empty()) return;
  // Stable: each voxel's hits and misses stay in the order they were added, as the map
  // applied them, so clamping cuts where it cut in the map.
  sortKeyCodes(added_);
  merge(added_, [this](float log_odds, std::uint64_t code) {
    return log_odds + ((code & kHit) ? model_.hit : model_.miss);
  });
  std::vector<std::uint64_t>().swap(added_);
}

void Submap::close() {
  fold();
  closed_ = true;
}

void Submap::setDelta(const Pose3& delta) {
  delta_ = delta;
  moved_ = !delta.isApprox(Pose3::Identity(), 1e-12);
}

std::pair<octomap::OcTreeKey, octomap::OcTreeKey> Submap::bounds(
    const octomap::OcTree& grid) const {
  if (voxels() == 0) return {min_, max_};
  const octomap::point3d lo = grid.keyToCoord(min_);
  const octomap::point3d hi = grid.keyToCoord(max_);
  Eigen::Vector3d min = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d max = -min;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d c((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                            (corner & 4) ? hi.z() : lo.z());
    min = min.cwiseMin(delta_ * c);
    max = max.cwiseMax(delta_ * c);
  }
  const double res = grid.getResolution();
  octomap::OcTreeKey min_key;
  octomap::OcTreeKey max_key;
  for (int a = 0; a < 3; ++a) {
    min_key[a] = grid.coordToKey(std::max(min[a] - res, -grid.getNodeSize(0) / 2 * 0.999));
    max_key[a] = grid.coordToKey(std::min(max[a] + res, grid.getNodeSize(0) / 2 * 0.999));
  }
  return {min_key, max_key};
}

std::size_t Submap::bytes() const {
  return voxels_.capacity() * sizeof(Voxel) + added_.capacity() * sizeof(std::uint64_t);
}

}  // namespace ccir_mapping::core::information
