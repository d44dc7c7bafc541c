// The occupancy evidence of a few consecutive scans of one robot (MapperParams::submap_scans),
// kept apart from the map so that the map can move it as one block when the back end moves its
// scans (re-anchoring) instead of integrating the scans again. Its voxels are keys of the map
// frame as it was when the scans were integrated; delta() moves them to where they are now.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/flat_key_set.h"
#include "ccir_mapping/core/information/occupancy_map.h"

namespace ccir_mapping::core::information {

class Submap {
 public:
  /// OctoMap's sensor model and clamping bounds, in log-odds (those of the map's tree).
  struct Model {
    float hit = 0.0F;
    float miss = 0.0F;
    float min = 0.0F;
    float max = 0.0F;
    static Model of(const octomap::OcTree& tree);
  };

  explicit Submap(Model model) : model_(model) {}

  /// Adds a scan's update as the map inserts it: each voxel one hit or miss, clamped. Kept as
  /// it came (8 bytes a voxel) until fold().
  void add(const ScanUpdate& update);
  /// Adds voxels with their log-odds (a map read from a file).
  void add(const octomap::OcTreeKey& key, float log_odds);
  /// Folds what was added into the evidence (one log-odds per voxel, in key order).
  void fold();
  /// Adds another submap's evidence at its place now (log-odds summed, clamped): what the
  /// settled part of the map is made of.
  void absorb(const Submap& other, const octomap::OcTree& grid);
  /// No more scans: folds them.
  void close();
  bool closed() const { return closed_; }

  /// The transform from the map frame the evidence was integrated in to where it belongs now.
  const Pose3& delta() const { return delta_; }
  void setDelta(const Pose3& delta);
  bool moved() const { return moved_; }

  /// Calls f(key, log_odds_mils) for each voxel of the folded evidence at its place now (the
  /// voxel holding its centre moved by delta(); one that leaves OctoMap's reach is skipped).
  template <class F>
  void forEach(const octomap::OcTree& grid, F&& f) const {
    for (const Voxel& v : voxels_) {
      if (!moved_) {
        f(v.key, v.log_odds_mils);
        continue;
      }
      const octomap::point3d c = grid.keyToCoord(v.key);
      const Eigen::Vector3d at = delta_ * Eigen::Vector3d(c.x(), c.y(), c.z());
      octomap::OcTreeKey moved;
      if (grid.coordToKeyChecked(octomap::point3d(at.x(), at.y(), at.z()), moved))
        f(moved, v.log_odds_mils);
    }
  }

  /// forEach() over the voxels in the key box [lo, hi] only: for a submap that never moved, a
  /// slice of its evidence (it is in key order, x first).
  template <class F>
  void forEachWithin(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi,
                     const octomap::OcTree& grid, F&& f) const {
    const auto inside = [&](const octomap::OcTreeKey& k) {
      return k[0] >= lo[0] && k[0] <= hi[0] && k[1] >= lo[1] && k[1] <= hi[1] && k[2] >= lo[2] &&
             k[2] <= hi[2];
    };
    if (moved_) {
      return forEach(grid, [&](const octomap::OcTreeKey& k, std::int16_t mils) {
        if (inside(k)) f(k, mils);
      });
    }
    const auto first =
        std::lower_bound(voxels_.begin(), voxels_.end(), octomap::OcTreeKey(lo[0], 0, 0),
                         [](const Voxel& v, const octomap::OcTreeKey& k) {
                           return FlatKeySet::pack(v.key) < FlatKeySet::pack(k);
                         });
    for (auto v = first; v != voxels_.end() && v->key[0] <= hi[0]; ++v) {
      if (inside(v->key)) f(v->key, v->log_odds_mils);
    }
  }

  /// The key box forEach() reaches, grown by a voxel; {max, min} keys when it holds nothing.
  std::pair<octomap::OcTreeKey, octomap::OcTreeKey> bounds(const octomap::OcTree& grid) const;
  std::size_t voxels() const { return voxels_.size(); }
  std::size_t bytes() const;

 private:
  struct Voxel {
    octomap::OcTreeKey key;
    std::int16_t log_odds_mils;  // |log-odds| stays below the clamping bounds' (~4.6)
  };
  static constexpr std::uint64_t kHit = std::uint64_t{1} << 48;
  void grow(const octomap::OcTreeKey& key);
  /// Merges `codes` (a packed key in the low 48 bits, sorted stably by it) into the evidence:
  /// each voxel's log-odds goes through step(log_odds, code) for each of its codes in turn.
  template <class Step>
  void merge(std::vector<std::uint64_t>& codes, Step step);

  Model model_;
  std::vector<Voxel> voxels_;         // folded, in key order (FlatKeySet::pack)
  std::vector<std::uint64_t> added_;  // since: packed key, kHit for a hit, in the order added
  octomap::OcTreeKey min_{octomap::key_type(0xFFFF), octomap::key_type(0xFFFF),
                          octomap::key_type(0xFFFF)};
  octomap::OcTreeKey max_{0, 0, 0};
  Pose3 delta_ = Pose3::Identity();
  bool moved_ = false;
  bool closed_ = false;
  bool unsorted_ = false;  // voxels_ after add(key, log_odds)
};

}  // namespace ccir_mapping::core::information
