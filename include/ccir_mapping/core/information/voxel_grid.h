// The known voxels of an occupancy map and their log-odds, in bricks of 8 x 8 x 8 voxels (a
// float each, NaN while unknown) found through a hash of the bricks' codes. A mine's known space
// is volumes of free space bounded by walls, so most bricks are full: ~4 – 5 bytes a known
// voxel, where OctoMap's octree takes ~28 (a 16-byte node per voxel and an array of 8 child
// pointers per 8 of them), for the same float log-odds. Written by hand: OctoMap stores only
// trees, and neither PCL nor Eigen has a sparse grid with a value per voxel.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include <octomap/OcTreeKey.h>

#include "ccir_mapping/core/information/key_bricks.h"

namespace ccir_mapping::core::information {

class VoxelGrid {
 public:
  /// The voxel's log-odds, or nullptr while it is unknown.
  const float* find(const octomap::OcTreeKey& key) const {
    const std::uint64_t code = KeyBricks::morton(key);
    const auto it = index_.find(code >> 9);
    if (it == index_.end()) return nullptr;
    const float* value = &bricks_[it->second]->log_odds[code & 511];
    return std::isnan(*value) ? nullptr : value;
  }

  /// The voxel's log-odds; an unknown voxel becomes known at 0 (an even chance) and `created`
  /// says so.
  float& at(const octomap::OcTreeKey& key, bool& created) {
    const std::uint64_t code = KeyBricks::morton(key);
    Brick& brick = brickOf(code >> 9);
    float& value = brick.log_odds[code & 511];
    created = std::isnan(value);
    if (created) {
      value = 0.0F;
      ++brick.known;
      ++voxels_;
    }
    return value;
  }

  /// Makes the voxel unknown; a brick left with no known voxel is released.
  void erase(const octomap::OcTreeKey& key) {
    const std::uint64_t code = KeyBricks::morton(key);
    const auto it = index_.find(code >> 9);
    if (it == index_.end()) return;
    Brick& brick = *bricks_[it->second];
    float& value = brick.log_odds[code & 511];
    if (std::isnan(value)) return;
    value = kUnknown;
    --voxels_;
    if (--brick.known > 0) return;
    bricks_[it->second].reset();
    free_.push_back(it->second);
    if (last_ == it->second) last_ = kNone;
    index_.erase(it);
  }

  void clear() { *this = VoxelGrid(); }

  /// Known voxels.
  std::size_t voxels() const { return voxels_; }
  /// Memory held, bricks and index.
  std::size_t bytes() const {
    return (bricks_.size() - free_.size()) * sizeof(Brick) +
           index_.size() *
               (sizeof(std::pair<const std::uint64_t, std::uint32_t>) + 2 * sizeof(void*)) +
           index_.bucket_count() * sizeof(void*) + bricks_.capacity() * sizeof(bricks_[0]);
  }

  /// f(key, log_odds) for every known voxel, in the octree's depth-first order (Morton order,
  /// as KeyBricks::inTreeOrder), so that a tree built from them grows in order.
  template <class F>
  void forEach(F&& f) const {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order(index_.begin(), index_.end());
    std::sort(order.begin(), order.end());
    for (const auto& [brick_code, i] : order) {
      const Brick& brick = *bricks_[i];
      for (unsigned v = 0; v < kBrickVoxels; ++v) {
        if (!std::isnan(brick.log_odds[v])) {
          f(KeyBricks::fromMorton(brick_code << 9 | v), brick.log_odds[v]);
        }
      }
    }
  }

  /// f(key, log_odds) for every known voxel with min[a] <= key[a] <= max[a] on each axis, in
  /// no particular order.
  template <class F>
  void forEachIn(const octomap::OcTreeKey& min, const octomap::OcTreeKey& max, F&& f) const {
    for (const auto& [brick_code, i] : index_) {
      const octomap::OcTreeKey corner = KeyBricks::fromMorton(brick_code << 9);
      bool inside = true;  // the whole brick
      bool apart = false;  // none of it
      for (int a = 0; a < 3; ++a) {
        inside &= corner[a] >= min[a] && corner[a] + 7 <= max[a];
        apart |= corner[a] > max[a] || corner[a] + 7 < min[a];
      }
      if (apart) continue;
      const Brick& brick = *bricks_[i];
      for (unsigned v = 0; v < kBrickVoxels; ++v) {
        if (std::isnan(brick.log_odds[v])) continue;
        const octomap::OcTreeKey key = KeyBricks::fromMorton(brick_code << 9 | v);
        if (inside || (key[0] >= min[0] && key[0] <= max[0] && key[1] >= min[1] &&
                       key[1] <= max[1] && key[2] >= min[2] && key[2] <= max[2])) {
          f(key, brick.log_odds[v]);
        }
      }
    }
  }

 private:
  static constexpr unsigned kBrickVoxels = 512;
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  static constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
  struct Brick {
    Brick() { log_odds.fill(kUnknown); }
    std::array<float, kBrickVoxels> log_odds;  // by the voxel's Morton code within the brick
    std::uint32_t known = 0;
  };

  /// The brick with that code, added if new; the last one used first (keys come in tree order,
  /// mostly many to a brick).
  Brick& brickOf(std::uint64_t brick_code) {
    if (last_ != kNone && last_code_ == brick_code) return *bricks_[last_];
    auto [it, added] = index_.try_emplace(brick_code, kNone);
    if (added) {
      if (free_.empty()) {
        it->second = static_cast<std::uint32_t>(bricks_.size());
        bricks_.push_back(std::make_unique<Brick>());
      } else {
        it->second = free_.back();
        free_.pop_back();
        bricks_[it->second] = std::make_unique<Brick>();
      }
    }
    last_ = it->second;
    last_code_ = brick_code;
    return *bricks_[last_];
  }

  std::vector<std::unique_ptr<Brick>> bricks_;  // null: released, its slot in free_
  std::vector<std::uint32_t> free_;
  std::unordered_map<std::uint64_t, std::uint32_t> index_;  // brick code -> bricks_
  std::size_t voxels_ = 0;
  std::uint32_t last_ = kNone;
  std::uint64_t last_code_ = 0;
};

}  // namespace ccir_mapping::core::information
