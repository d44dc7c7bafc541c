// The occupancy evidence of a few consecutive scans of one robot (MapperParams::submap_scans),
// kept apart from the map so that the map can move it as one block when the back end moves its
// scans (re-anchoring) instead of integrating the scans again. Its voxels are keys of the map
// frame as it was when the scans were integrated; delta() moves them to where they are now.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/key_codes.h"
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
  /// it came (8 bytes a voxel) until fold(), which happens here too once what came since the
  /// last fold is as large as the evidence: consecutive scans share most voxels, so a live
  /// submap holds about its distinct voxels rather than every scan's, at an amortised O(1) per
  /// voxel added.
  void add(const ScanUpdate& update);
  /// Folds what was added into the evidence (one log-odds per voxel, in key order).
  void fold();
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
    if (!moved_) {
      for (const Voxel& v : voxels_) f(v.key, v.log_odds_mils);
      return;
    }
    // delta() in key units: the key holding the moved centre of key k is floor(r k + b), where
    // keyToCoord, the transform and coordToKeyChecked took three conversions a voxel.
    const double centre = static_cast<double>(1U << (grid.getTreeDepth() - 1));
    const double span = 2.0 * centre;
    const Eigen::Matrix3d r = delta_.linear();
    const Eigen::Vector3d b = r * Eigen::Vector3d::Constant(0.5 - centre) +
                              delta_.translation() / grid.getResolution() +
                              Eigen::Vector3d::Constant(centre);
    for (const Voxel& v : voxels_) {
      const Eigen::Vector3d at = r * Eigen::Vector3d(v.key[0], v.key[1], v.key[2]) + b;
      if (at.minCoeff() < 0.0 || at.maxCoeff() >= span) continue;  // beyond OctoMap's reach
      f(octomap::OcTreeKey(static_cast<octomap::key_type>(at.x()),
                           static_cast<octomap::key_type>(at.y()),
                           static_cast<octomap::key_type>(at.z())),
        v.log_odds_mils);
    }
  }

  /// For a submap that never moved: f(key, log_odds_mils) for each voxel whose packed key
  /// (packKey) is among `codes` (sorted), by merging the two sorted sequences (each
  /// skipping ahead by galloping where the other is sparse): reading the evidence in order
  /// instead of probing a hash set of `codes` voxel by voxel, which missed the cache for most.
  template <class F>
  void forEachAmong(const std::vector<std::uint64_t>& codes, F&& f) const {
    const auto voxel_before = [](const Voxel& voxel, std::uint64_t code) {
      return packKey(voxel.key) < code;
    };
    auto c = codes.begin();
    auto v = voxels_.begin();
    while (v != voxels_.end() && c != codes.end()) {
      const std::uint64_t at = packKey(v->key);
      if (at < *c) {
        v = gallop(v, voxels_.end(), *c, voxel_before);
      } else if (*c < at) {
        c = gallop(c, codes.end(), at, std::less<std::uint64_t>());
      } else {
        f(v->key, v->log_odds_mils);
        ++v;
        ++c;
      }
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
  /// The first element of [first, last) not before `value`, found by steps doubling from
  /// `first` and a binary search within the last step: O(log) of the distance skipped.
  template <class It, class T, class Before>
  static It gallop(It first, It last, const T& value, Before before) {
    std::ptrdiff_t step = 1;
    while (last - first > step && before(first[step], value)) {
      first += step;
      step *= 2;
    }
    return std::lower_bound(first, first + std::min<std::ptrdiff_t>(step, last - first), value,
                            before);
  }
  void grow(const octomap::OcTreeKey& key);
  /// Merges `codes` (a packed key in the low 48 bits, sorted stably by it) into the evidence:
  /// each voxel's log-odds goes through step(log_odds, code) for each of its codes in turn.
  template <class Step>
  void merge(std::vector<std::uint64_t>& codes, Step step);

  Model model_;
  std::vector<Voxel> voxels_;         // folded, in key order (packKey)
  std::vector<std::uint64_t> added_;  // since: packed key, kHit for a hit, in the order added
  octomap::OcTreeKey min_{octomap::key_type(0xFFFF), octomap::key_type(0xFFFF),
                          octomap::key_type(0xFFFF)};
  octomap::OcTreeKey max_{0, 0, 0};
  Pose3 delta_ = Pose3::Identity();
  bool moved_ = false;
  bool closed_ = false;
};

}  // namespace ccir_mapping::core::information
