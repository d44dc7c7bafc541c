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
  void addSettled(const VoxelGrid& map);
  /// Submap `id` joins the settled part of the map where it is now: it never moves again, and
  /// its evidence counts once per voxel there (8 bytes a voxel of the settled part). The settled
  /// part is a few sorted runs, each at least kRunRatio times smaller than the one before: a
  /// run is merged into the one before once it is no longer, so a settle costs amortised
  /// O(log) per voxel instead of a pass over the whole settled part, for at most 1 / (kRunRatio
  /// - 1) more bytes (a voxel in several runs).
  void settle(SubmapId id);
  static constexpr std::size_t kRunRatio = 4;
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
  /// Runs of the settled part.
  std::size_t settledRuns() const { return settled_.size(); }
  std::size_t voxels() const;
  std::size_t bytes() const;

 private:
  Submap& submap(SubmapId id);
  /// A run joins the settled part; smaller runs are merged into larger ones (kRunRatio).
  void addRun(Submap run);

  const octomap::OcTree& grid_;
  std::map<SubmapId, Submap> submaps_;
  std::vector<Submap> settled_;  // the settled part's runs, largest first
  std::size_t visited_ = 0;
};

}  // namespace ccir_mapping::core::information
