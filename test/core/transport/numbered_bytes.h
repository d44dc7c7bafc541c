// Test messages that carry their number: `size` bytes starting with `n` (little-endian), the
// rest filled with its low byte; number() reads it back.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ccir_mapping::test {

inline std::vector<std::uint8_t> numbered(std::size_t size, std::uint32_t n) {
  std::vector<std::uint8_t> bytes(size, static_cast<std::uint8_t>(n));
  for (int i = 0; i < 4; ++i) bytes[i] = static_cast<std::uint8_t>(n >> (8 * i));
  return bytes;
}

inline std::uint32_t number(const std::vector<std::uint8_t>& bytes) {
  std::uint32_t n = 0;
  for (int i = 0; i < 4; ++i) n |= static_cast<std::uint32_t>(bytes[i]) << (8 * i);
  return n;
}

}  // namespace ccir_mapping::test
