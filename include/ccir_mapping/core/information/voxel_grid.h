// A value per known voxel (an occupancy map's log-odds, the settled evidence), in bricks of
// 8 x 8 x 8 voxels found through a hash of the bricks' codes; an unknown voxel holds NaN, or the
// lowest integer. A mine's known space is volumes of free space bounded by walls, so most bricks
// are full: a float map takes ~6 – 8 bytes a known voxel on the team missions (bricks at the
// edge of the known space are partly empty), where OctoMap's octree takes ~28 (a 16-byte node
// per voxel and an array of 8 child pointers per 8 of them) for the same float log-odds.
// Written by hand: OctoMap stores only trees, and neither PCL nor Eigen has a sparse grid with a
// value per voxel.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include <octomap/OcTreeKey.h>

#include "ccir_mapping/core/information/key_bricks.h"

namespace ccir_mapping::core::information {

template <class Value>
class VoxelGrid {
 public:
  /// The voxel's value, or nullptr while it is unknown.
  const Value* find(const octomap::OcTreeKey& key) const {
    const std::uint64_t code = KeyBricks::morton(key);
    const auto it = index_.find(code >> 9);
    if (it == index_.end()) return nullptr;
    const Value* value = &bricks_[it->second]->values[code & 511];
    return unknown(*value) ? nullptr : value;
  }

  /// The voxel's value; an unknown voxel becomes known at 0 (log-odds: an even chance) and
  /// `created` says so.
  Value& at(const octomap::OcTreeKey& key, bool& created) {
    const std::uint64_t code = KeyBricks::morton(key);
    Brick& brick = brickOf(code >> 9);
    Value& value = brick.values[code & 511];
    created = unknown(value);
    if (created) {
      value = 0;
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
    Value& value = brick.values[code & 511];
    if (unknown(value)) return;
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

  /// f(key, value) for every known voxel, in the octree's depth-first order (Morton order,
  /// as KeyBricks::inTreeOrder), so that a tree built from them grows in order.
  template <class F>
  void forEach(F&& f) const {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order(index_.begin(), index_.end());
    std::sort(order.begin(), order.end());
    for (const auto& [brick_code, i] : order) {
      const Brick& brick = *bricks_[i];
      for (unsigned v = 0; v < kBrickVoxels; ++v) {
        if (!unknown(brick.values[v]))
          f(KeyBricks::fromMorton(brick_code << 9 | v), brick.values[v]);
      }
    }
  }

  /// f(key, value) for every known voxel with min[a] <= key[a] <= max[a] on each axis, in
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
        if (unknown(brick.values[v])) continue;
        const octomap::OcTreeKey key = KeyBricks::fromMorton(brick_code << 9 | v);
        if (inside || (key[0] >= min[0] && key[0] <= max[0] && key[1] >= min[1] &&
                       key[1] <= max[1] && key[2] >= min[2] && key[2] <= max[2])) {
          f(key, brick.values[v]);
        }
      }
    }
  }

 private:
  static constexpr unsigned kBrickVoxels = 512;
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  static constexpr Value kUnknown = std::is_floating_point_v<Value>
                                        ? std::numeric_limits<Value>::quiet_NaN()
                                        : std::numeric_limits<Value>::lowest();
  static bool unknown(Value v) {
    if constexpr (std::is_floating_point_v<Value>) {
      return std::isnan(v);
    } else {
      return v == kUnknown;
    }
  }
  struct Brick {
    Brick() { values.fill(kUnknown); }
    std::array<Value, kBrickVoxels> values;  // by the voxel's Morton code within the brick
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
