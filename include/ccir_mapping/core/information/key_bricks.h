// A set of OctoMap voxel keys as the bits of 8 x 8 x 8 bricks. A scan's update visits ~1 M ray
// cells of which ~150 k are distinct, and the cells of a ray follow each other through the same
// few bricks: a cell costs a shift and an OR in the brick of the cell before it, where a hash
// set probed a slot per cell, and the keys come out in the octree's depth-first order by sorting
// the few thousand bricks instead of every key. Written by hand: OctoMap's KeySet is a
// node-based unordered_set, and neither it nor Eigen or PCL has a sparse bit grid.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <octomap/OcTreeKey.h>

namespace ccir_mapping::core::information {

class KeyBricks {
 public:
  KeyBricks() { index_.assign(kInitialSlots, kNone); }

  void insert(const octomap::OcTreeKey& key) {
    const unsigned bit = local(key);
    bricks_[brickOf(key)].bits[bit >> 6] |= std::uint64_t{1} << (bit & 63);
  }
  bool contains(const octomap::OcTreeKey& key) const {
    const std::uint32_t at = find(brickCode(key));
    const unsigned bit = local(key);
    return at != kNone && ((bricks_[at].bits[bit >> 6] >> (bit & 63)) & 1);
  }
  bool empty() const { return bricks_.empty(); }

  /// Calls f(key) for every key, brick by brick.
  template <class F>
  void forEach(F&& f) const {
    for (const Brick& b : bricks_) {
      for (unsigned w = 0; w < 8; ++w) {
        for (std::uint64_t word = b.bits[w]; word; word &= word - 1) {
          const auto bit = static_cast<unsigned>(__builtin_ctzll(word));
          f(fromMorton(b.code << 9 | (w << 6 | bit)));
        }
      }
    }
  }

  /// The keys in the octree's depth-first order (Morton order of x, y, z as OctoMap numbers its
  /// children), leaving out those `except` holds: updating them one after the other visits the
  /// map's bricks (VoxelGrid) one at a time, many keys each.
  std::vector<octomap::OcTreeKey> inTreeOrder(const KeyBricks* except = nullptr) const {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order;  // brick code, index
    order.reserve(bricks_.size());
    for (std::uint32_t i = 0; i < bricks_.size(); ++i) order.emplace_back(bricks_[i].code, i);
    std::sort(order.begin(), order.end());
    std::vector<octomap::OcTreeKey> keys;
    keys.reserve(bricks_.size() * 32);
    for (const auto& [code, i] : order) {
      const std::uint32_t other = except ? except->find(code) : kNone;
      for (unsigned w = 0; w < 8; ++w) {
        std::uint64_t word = bricks_[i].bits[w];
        if (other != kNone) word &= ~except->bricks_[other].bits[w];
        while (word) {
          const auto bit = static_cast<unsigned>(__builtin_ctzll(word));
          word &= word - 1;
          keys.push_back(fromMorton(code << 9 | (w << 6 | bit)));
        }
      }
    }
    return keys;
  }

  /// Bit i of x, y and z goes to bits 3i, 3i + 1 and 3i + 2 (computeChildIdx's order).
  static std::uint64_t morton(const octomap::OcTreeKey& k) {
    return spread3(k[0]) | spread3(k[1]) << 1 | spread3(k[2]) << 2;
  }
  static octomap::OcTreeKey fromMorton(std::uint64_t code) {
    return {static_cast<octomap::key_type>(compact3(code)),
            static_cast<octomap::key_type>(compact3(code >> 1)),
            static_cast<octomap::key_type>(compact3(code >> 2))};
  }

 private:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  static constexpr std::size_t kInitialSlots = 1024;
  struct Brick {
    std::uint64_t code;  // Morton code of the key's upper 13 bits per axis
    std::array<std::uint64_t, 8> bits{};
  };

  /// The Morton code of the brick holding the key, and the key's bit in it (its low 3 bits per
  /// axis interleaved: a brick's bits in order are its keys in Morton order).
  static std::uint64_t brickCode(const octomap::OcTreeKey& k) { return morton(k) >> 9; }
  static unsigned local(const octomap::OcTreeKey& k) {
    return static_cast<unsigned>(morton(k) & 511);
  }
  static std::uint64_t spread3(std::uint64_t v) {
    v &= 0xFFFF;
    v = (v | v << 16) & 0x0000FF0000FFULL;
    v = (v | v << 8) & 0x00F00F00F00FULL;
    v = (v | v << 4) & 0x0C30C30C30C3ULL;
    v = (v | v << 2) & 0x249249249249ULL;
    return v;
  }
  static std::uint64_t compact3(std::uint64_t v) {
    v &= 0x249249249249ULL;
    v = (v | v >> 2) & 0x0C30C30C30C3ULL;
    v = (v | v >> 4) & 0x00F00F00F00FULL;
    v = (v | v >> 8) & 0x0000FF0000FFULL;
    v = (v | v >> 16) & 0xFFFF;
    return v;
  }
  std::size_t slot(std::uint64_t code) const {
    return static_cast<std::size_t>((code * 0x9E3779B97F4A7C15ULL) >> 20) & (index_.size() - 1);
  }
  std::uint32_t find(std::uint64_t code) const {
    for (std::size_t i = slot(code);; i = (i + 1) & (index_.size() - 1)) {
      if (index_[i] == kNone || bricks_[index_[i]].code == code) return index_[i];
    }
  }
  /// The brick holding the key, added if new; the last one found first (a ray's next cell).
  std::uint32_t brickOf(const octomap::OcTreeKey& key) {
    const std::uint64_t code = brickCode(key);
    if (last_ != kNone && bricks_[last_].code == code) return last_;
    std::size_t i = slot(code);
    for (; index_[i] != kNone; i = (i + 1) & (index_.size() - 1)) {
      if (bricks_[index_[i]].code == code) return last_ = index_[i];
    }
    last_ = index_[i] = static_cast<std::uint32_t>(bricks_.size());
    bricks_.push_back({code, {}});
    if (2 * bricks_.size() > index_.size()) rehash();
    return last_;
  }
  void rehash() {
    index_.assign(2 * index_.size(), kNone);
    for (std::uint32_t b = 0; b < bricks_.size(); ++b) {
      std::size_t i = slot(bricks_[b].code);
      while (index_[i] != kNone) i = (i + 1) & (index_.size() - 1);
      index_[i] = b;
    }
  }

  std::vector<Brick> bricks_;
  std::vector<std::uint32_t> index_;  // open addressing on brick codes, into bricks_
  std::uint32_t last_ = kNone;
};

}  // namespace ccir_mapping::core::information
