#include "ccir_mapping/core/common/compression.h"

#include <zstd.h>

namespace ccir_mapping::core {

std::vector<std::uint8_t> compress(const std::vector<std::uint8_t>& message, int level) {
  std::vector<std::uint8_t> out(ZSTD_compressBound(message.size()));
  const std::size_t size =
      ZSTD_compress(out.data(), out.size(), message.data(), message.size(), level);
  out.resize(ZSTD_isError(size) ? 0 : size);
  return out;
}

std::optional<std::vector<std::uint8_t>> decompress(const std::vector<std::uint8_t>& compressed,
                                                    std::size_t max_bytes) {
  // The frame header states the size; check it before allocating anything.
  const unsigned long long size = ZSTD_getFrameContentSize(compressed.data(), compressed.size());
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > max_bytes ||
      ZSTD_findFrameCompressedSize(compressed.data(), compressed.size()) != compressed.size()) {
    return std::nullopt;
  }
  std::vector<std::uint8_t> out(size);
  const std::size_t got =
      ZSTD_decompress(out.data(), out.size(), compressed.data(), compressed.size());
  if (ZSTD_isError(got) || got != size) return std::nullopt;
  return out;
}

}  // namespace ccir_mapping::core
