// The best entropy drop any of a set of scans brings each voxel (or block): the value of that
// set under the facility-location objective the scan ranking maximises. CCIR holds one per
// teammate as its belief of what that teammate's map already knows.
#pragma once

#include <algorithm>
#include <unordered_map>
#include <vector>

#include "ccir_mapping/core/information/occupancy_map.h"

namespace ccir_mapping::core::information {

class Coverage {
 public:
  float best(const octomap::OcTreeKey& key) const {
    const auto it = best_.find(key);
    return it == best_.end() ? 0.0F : it->second;
  }
  void add(const std::vector<VoxelGain>& gains) {
    for (const auto& [key, gain] : gains) {
      float& best = best_[key];
      best = std::max(best, gain);
    }
  }
  /// What `gains` adds beyond what is covered: sum of max(0, gain - best).
  double marginal(const std::vector<VoxelGain>& gains) const {
    double sum = 0.0;
    for (const auto& [key, gain] : gains) sum += std::max(0.0F, gain - best(key));
    return sum;
  }
  std::size_t size() const { return best_.size(); }
  void clear() { best_.clear(); }

 private:
  std::unordered_map<octomap::OcTreeKey, float, octomap::OcTreeKey::KeyHash> best_;
};

}  // namespace ccir_mapping::core::information
