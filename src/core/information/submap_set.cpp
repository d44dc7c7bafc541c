#include "ccir_mapping/core/information/submap_set.h"

#include <algorithm>
#include <cmath>

#include "ccir_mapping/core/information/key_bricks.h"
#include "ccir_mapping/core/information/key_codes.h"

namespace ccir_mapping::core::information {

Submap& SubmapSet::submap(SubmapId id) {
  return submaps_.try_emplace(id, Submap::Model::of(grid_)).first->second;
}

void SubmapSet::add(SubmapId id, const ScanUpdate& update) { submap(id).add(update); }

void SubmapSet::addSettled(const VoxelGrid<float>& map) {
  const Submap::Model model = Submap::Model::of(grid_);
  map.forEach([&](const octomap::OcTreeKey& key, float log_odds) {
    settleVoxel(key, static_cast<std::int16_t>(
                         std::lround(std::clamp(log_odds, model.min, model.max) * 1e3F)));
  });
}

void SubmapSet::settleVoxel(const octomap::OcTreeKey& key, std::int16_t mils) {
  const Submap::Model model = Submap::Model::of(grid_);
  bool created = false;
  std::int16_t& settled = settled_.at(key, created);
  settled = static_cast<std::int16_t>(std::clamp(static_cast<int>(settled) + mils,
                                                 static_cast<int>(std::lround(model.min * 1e3F)),
                                                 static_cast<int>(std::lround(model.max * 1e3F))));
}

void SubmapSet::settle(SubmapId id) {
  const auto it = submaps_.find(id);
  if (it == submaps_.end()) return;
  it->second.close();
  it->second.forEach(
      grid_, [&](const octomap::OcTreeKey& key, std::int16_t mils) { settleVoxel(key, mils); });
  submaps_.erase(it);
}

void SubmapSet::close(SubmapId id) {
  if (const auto it = submaps_.find(id); it != submaps_.end()) it->second.close();
}

SubmapSet::Voxels SubmapSet::apply(const std::vector<Change>& changes) {
  // The voxels to recompute: where the changed submaps were, and where they are now.
  KeyBricks affected;
  visited_ = 0;
  const auto mark = [&](const octomap::OcTreeKey& key, std::int16_t) {
    affected.insert(key);
    ++visited_;
  };
  for (const Change& change : changes) {
    Submap& s = submap(change.id);
    s.fold();
    s.forEach(grid_, mark);
    if (change.updates) {
      s = Submap(Submap::Model::of(grid_));
      for (const auto& update : *change.updates) s.add(update);
      s.close();
    }
    s.setDelta(change.delta);
    s.forEach(grid_, mark);
  }
  if (affected.empty()) return {};
  octomap::OcTreeKey lo(0xFFFF, 0xFFFF, 0xFFFF);
  octomap::OcTreeKey hi(0, 0, 0);
  std::vector<std::uint64_t> keys;
  affected.forEach([&](const octomap::OcTreeKey& key) {
    keys.push_back(packKey(key));
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], key[a]);
      hi[a] = std::max(hi[a], key[a]);
    }
  });
  sortKeyCodes(keys);
  // What every submap that reaches them and the settled part say of them: the key, and the
  // log-odds above it.
  std::vector<std::uint64_t> said;
  const auto say = [&](const octomap::OcTreeKey& key, std::int16_t mils) {
    said.push_back(packKey(key) | std::uint64_t{static_cast<std::uint16_t>(mils)} << 48);
  };
  const auto gather = [&](Submap& s) {
    const auto [min, max] = s.bounds(grid_);
    bool overlaps = true;
    for (int a = 0; a < 3; ++a) overlaps &= min[a] <= hi[a] && lo[a] <= max[a];
    if (!overlaps) return;
    s.fold();
    if (!s.moved()) return s.forEachAmong(keys, say);
    visited_ += s.voxels();
    s.forEach(grid_, [&](const octomap::OcTreeKey& key, std::int16_t mils) {
      if (affected.contains(key)) say(key, mils);
    });
  };
  for (auto& [id, s] : submaps_) gather(s);
  for (const std::uint64_t code : keys) {
    const octomap::OcTreeKey key = unpackKey(code);
    if (const std::int16_t* mils = settled_.find(key)) say(key, *mils);
  }
  sortKeyCodes(said);
  visited_ += said.size() + keys.size();
  const Submap::Model model = Submap::Model::of(grid_);
  constexpr std::uint64_t kKey = (std::uint64_t{1} << 48) - 1;
  Voxels voxels;
  voxels.reserve(keys.size());
  std::size_t j = 0;
  for (const std::uint64_t key : keys) {
    std::optional<float> log_odds;
    for (; j < said.size() && (said[j] & kKey) == key; ++j) {
      const auto mils = static_cast<std::int16_t>(said[j] >> 48);
      log_odds = log_odds.value_or(0.0F) + static_cast<float>(mils) * 1e-3F;
    }
    if (log_odds) log_odds = std::clamp(*log_odds, model.min, model.max);
    voxels.emplace_back(unpackKey(key), log_odds);
  }
  return voxels;
}

std::size_t SubmapSet::voxels() const {
  std::size_t n = 0;
  for (const auto& [id, s] : submaps_) n += s.voxels();
  n += settled_.voxels();
  return n;
}

std::size_t SubmapSet::bytes() const {
  std::size_t n = 0;
  for (const auto& [id, s] : submaps_) n += s.bytes();
  n += settled_.bytes();
  return n;
}

}  // namespace ccir_mapping::core::information
