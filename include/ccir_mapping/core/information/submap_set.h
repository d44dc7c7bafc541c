// A robot's submaps and the map they make. Each voxel of the map holds the sum of the log-odds the
// submaps give it, clamped as OctoMap clamps: where submaps overlap a voxel is one voxel of the
// map, counted once by its entropy, known volume and information queries, with the evidence of
// all. A new scan goes into its submap and into the map at once (OccupancyMap::insert); moving
// or re-integrating submaps recomputes the map only where they were and where they are now, from
// the submaps that reach there, so its cost follows the submaps moved, not the map's size.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/submap.h"
#include "ccir_mapping/core/information/voxel_grid.h"

namespace ccir_mapping::core::information {

using SubmapId = std::uint32_t;

class SubmapSet {
 public:
  /// A submap moved to `delta` (Submap::delta), or integrated again from `updates` (its scans at
  /// their current poses, in the map frame: delta identity).
  struct Change {
    SubmapId id = 0;
    Pose3 delta = Pose3::Identity();
    std::optional<std::vector<ScanUpdate>> updates;
  };
  /// What the map's voxels become: a log-odds, or unknown.
  using Voxels = std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>>;

  /// `grid`: the map's grid (its keys and sensor model).
  explicit SubmapSet(const octomap::OcTree& grid) : grid_(grid) {}

  /// A scan's update into submap `id` (created if new); the caller inserts it into the map.
  void add(SubmapId id, const ScanUpdate& update);
  /// A map read from a file: the start of the settled part.
  void addSettled(const VoxelGrid<float>& map);
  /// Submap `id` joins the settled part of the map where it is now: it never moves again, and
  /// its evidence is summed (clamped) into the settled part's one value per voxel, log-odds in
  /// thousandths as a closed submap keeps them, in bricks (~2 bytes a voxel).
  void settle(SubmapId id);
  void close(SubmapId id);
  /// Applies the changes to the submaps and returns the voxels of the map that change with them
  /// (for OccupancyMap::assign).
  Voxels apply(const std::vector<Change>& changes);
  /// The voxels the last apply() read or wrote: those of the changed submaps where they were
  /// and are, of the moved submaps it gathered from (every one: they are not in key order
  /// where they are now), the evidence gathered and the map's voxels recomputed. What it cost
  /// follows this, where the map's voxels alone miss the submaps gathered from.
  std::size_t lastVisited() const { return visited_; }

  /// Submaps not settled.
  std::size_t size() const { return submaps_.size(); }
  /// Voxels of the submaps and of the settled part (a voxel in several counts for each).
  std::size_t voxels() const;
  std::size_t bytes() const;

 private:
  Submap& submap(SubmapId id);
  /// Evidence into the settled part: its voxel's log-odds plus `mils`, clamped.
  void settleVoxel(const octomap::OcTreeKey& key, std::int16_t mils);

  const octomap::OcTree& grid_;
  std::map<SubmapId, Submap> submaps_;
  VoxelGrid<std::int16_t> settled_;  // log-odds in thousandths
  std::size_t visited_ = 0;
};

}  // namespace ccir_mapping::core::information
