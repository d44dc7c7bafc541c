#include "ccir_mapping/core/information/scan_ranker.h"

#include <algorithm>
#include <queue>
#include <stdexcept>
#include <unordered_map>

namespace ccir_mapping::core::information {

std::vector<VoxelGain> coarsened(const std::vector<VoxelGain>& gains, int levels) {
  std::unordered_map<octomap::OcTreeKey, float, octomap::OcTreeKey::KeyHash> blocks;
  for (const auto& [key, gain] : gains) {
    const octomap::OcTreeKey block(static_cast<octomap::key_type>(key[0] >> levels),
                                   static_cast<octomap::key_type>(key[1] >> levels),
                                   static_cast<octomap::key_type>(key[2] >> levels));
    blocks[block] += gain;
  }
  std::vector<VoxelGain> result(blocks.begin(), blocks.end());
  // Hash order is the library's: sort, so sums and ties do not depend on it.
  std::sort(result.begin(), result.end(), [](const VoxelGain& a, const VoxelGain& b) {
    return std::lexicographical_compare(&a.first[0], &a.first[0] + 3, &b.first[0], &b.first[0] + 3);
  });
  return result;
}

ScanRanker::ScanRanker(std::vector<std::vector<VoxelGain>> gains, std::vector<double> bonus,
                       const Coverage* held)
    : owned_(std::move(gains)), bonus_(std::move(bonus)), held_(held) {
  for (const auto& g : owned_) gains_.push_back(&g);
  init();
}

ScanRanker::ScanRanker(std::vector<const std::vector<VoxelGain>*> gains, std::vector<double> bonus,
                       const Coverage* held, std::vector<double> held_marginals)
    : gains_(std::move(gains)), bonus_(std::move(bonus)), held_(held) {
  init(std::move(held_marginals));
}

void ScanRanker::init(std::vector<double> held_marginals) {
  if (bonus_.empty()) bonus_.assign(gains_.size(), 0.0);
  if (bonus_.size() != gains_.size()) {
    throw std::invalid_argument("ScanRanker: one bonus per scan, or none");
  }
  if (!held_marginals.empty()) {
    if (held_marginals.size() != gains_.size()) {
      throw std::invalid_argument("ScanRanker: one held marginal per scan, or none");
    }
    for (std::size_t i = 0; i < gains_.size(); ++i) alone_.push_back(bonus_[i] + held_marginals[i]);
    return;
  }
  // The same sums marginalGain() makes with nothing chosen yet, so rankings agree.
  const Coverage none;
  const Coverage& held = held_ ? *held_ : none;
  for (std::size_t i = 0; i < gains_.size(); ++i)
    alone_.push_back(bonus_[i] + held.marginal(*gains_[i]));
}

double ScanRanker::marginalGain(std::size_t scan, const Coverage& covered) const {
  ++evaluations_;
  double gain = bonus_[scan];
  for (const auto& [key, g] : *gains_[scan]) {
    const float best = std::max(covered.best(key), held_ ? held_->best(key) : 0.0F);
    gain += std::max(0.0F, g - best);
  }
  return gain;
}

std::vector<RankedScan> ScanRanker::rankNaive(std::size_t n) const {
  evaluations_ = 0;
  std::vector<RankedScan> ranked;
  std::vector<bool> chosen(gains_.size(), false);
  Coverage covered;
  while (ranked.size() < std::min(n, gains_.size())) {
    RankedScan best{gains_.size(), -1.0};
    for (std::size_t i = 0; i < gains_.size(); ++i) {
      if (chosen[i]) continue;
      const double gain = marginalGain(i, covered);
      if (best.index == gains_.size() || gain > best.gain) best = {i, gain};
    }
    chosen[best.index] = true;
    covered.add(*gains_[best.index]);
    ranked.push_back(best);
  }
  return ranked;
}

std::vector<RankedScan> ScanRanker::rankLazy(std::size_t n) const {
  evaluations_ = 0;
  // (gain, index, round it was evaluated in); the best is the largest gain, then lowest index.
  struct Entry {
    double gain;
    std::size_t index;
    std::size_t round;
  };
  auto worse = [](const Entry& a, const Entry& b) {
    return a.gain < b.gain || (a.gain == b.gain && a.index > b.index);
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(worse)> queue(worse);
  Coverage covered;
  for (std::size_t i = 0; i < gains_.size(); ++i) queue.push({alone_[i], i, 0});
  std::vector<RankedScan> ranked;
  while (ranked.size() < n && !queue.empty()) {
    Entry top = queue.top();
    queue.pop();
    if (top.round == ranked.size()) {
      // Fresh: every other gain is at most its stale value (submodularity), which is below.
      ranked.push_back({top.index, top.gain});
      covered.add(*gains_[top.index]);
      continue;
    }
    queue.push({marginalGain(top.index, covered), top.index, ranked.size()});
  }
  return ranked;
}

}  // namespace ccir_mapping::core::information
