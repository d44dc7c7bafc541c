// zstd on a byte message: the Bridge's optional compression before a message is cut into frames
// (the link counts the compressed bytes), and the scan codec's last step. Decompression is
// bounded, so a hostile frame cannot expand without limit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace ccir_mapping::core {

std::vector<std::uint8_t> compress(const std::vector<std::uint8_t>& message, int level = 3);
/// The original bytes, or nullopt when the input is not one zstd frame of at most `max_bytes`.
std::optional<std::vector<std::uint8_t>> decompress(const std::vector<std::uint8_t>& compressed,
                                                    std::size_t max_bytes);

}  // namespace ccir_mapping::core
