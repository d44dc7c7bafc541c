// Greedy sequential ranking of scans by the information they add to what a teammate is believed
// to hold (thesis Eq. 3.4), naive and lazy.
//
// Each candidate scan comes as the entropy it would remove from each voxel of that believed map
// (OccupancyMap::voxelGains, scaled by the caller, e.g. by k while the transform is unknown),
// plus a bonus independent of the others (the loop-closure utility). A ranked set S is worth
// sum_v max_{s in S} gain_s(v) + sum_{s in S} bonus_s: each voxel counts the best any chosen scan
// does for it. Inserting the chosen scans into the map instead would not be submodular (a voxel
// near p = 0.5 loses more entropy on its second observation than on its first), and lazy
// evaluation would then not return the greedy set; this objective is (a facility-location
// function), so the lazy ranking equals the naive one and is far cheaper.
#pragma once

#include <cstddef>
#include <vector>

#include "ccir_mapping/core/information/coverage.h"
#include "ccir_mapping/core/information/occupancy_map.h"

namespace ccir_mapping::core::information {

struct RankedScan {
  std::size_t index = 0;
  /// What the scan added when it was chosen: bonus + new voxel gains (bits).
  double gain = 0.0;
};

/// Gains summed over blocks of 2^levels voxels a side (keys shifted right), the unit the
/// ranking counts coverage in: at 0.1 m a keyframe touches ~300 k voxels but ~5 k blocks of
/// 0.8 m. Two scans that see different voxels of one block then count as one (the better).
std::vector<VoxelGain> coarsened(const std::vector<VoxelGain>& gains, int levels);

class ScanRanker {
 public:
  /// `gains[i]`: scan i's voxel gains; `bonus` empty or one per scan; `held`: what the
  /// receiver already has (counted as chosen before the first pick; must outlive the ranker).
  ScanRanker(std::vector<std::vector<VoxelGain>> gains, std::vector<double> bonus = {},
             const Coverage* held = nullptr);
  /// The same over gains the caller keeps (they must outlive the ranker): no copy.
  /// `held_marginals`: each scan's held->marginal when the caller has them already (empty: the
  /// ranker computes them).
  ScanRanker(std::vector<const std::vector<VoxelGain>*> gains, std::vector<double> bonus,
             const Coverage* held, std::vector<double> held_marginals = {});

  /// The best `n` scans in the order chosen; ties go to the lower index. O(n L C).
  std::vector<RankedScan> rankNaive(std::size_t n) const;
  /// The same ranking, re-evaluating a scan only when its stale gain could still be the best.
  std::vector<RankedScan> rankLazy(std::size_t n) const;
  /// Marginal gains evaluated by the last ranking (to compare the two).
  std::size_t evaluations() const { return evaluations_; }

 private:
  double marginalGain(std::size_t scan, const Coverage& covered) const;

  void init(std::vector<double> held_marginals = {});

  std::vector<std::vector<VoxelGain>> owned_;
  std::vector<const std::vector<VoxelGain>*> gains_;
  std::vector<double> bonus_;
  const Coverage* held_ = nullptr;
  /// What each scan is worth alone (its first marginal gain, without the lookups).
  std::vector<double> alone_;
  mutable std::size_t evaluations_ = 0;
};

}  // namespace ccir_mapping::core::information
