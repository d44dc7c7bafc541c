// Large messages cross a link as fragments (fragment_bytes each, 64 KB by default, as the
// thesis's radios carried packets), so a scan never holds the link for long and control
// messages can go between its fragments.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "ccir_mapping/core/transport/frame_codec.h"

namespace ccir_mapping::core::transport {

/// Data frames of at most `fragment_bytes` of payload each (one if the message fits), all with
/// the message's topic and sequence. Throws std::invalid_argument above 65535 fragments.
std::vector<Frame> fragmentMessage(std::uint16_t topic, std::uint64_t sequence,
                                   const std::vector<std::uint8_t>& message,
                                   std::size_t fragment_bytes, std::uint8_t flags = 0);

/// Puts fragments back together, in any order; bounded in message size, in how many messages
/// may be incomplete at once and in the bytes they hold together, a slot per announced fragment
/// counted (twice the largest message): to make room the oldest incomplete message is dropped.
/// A sender interleaves at most a few.
class Reassembler {
 public:
  Reassembler(std::size_t max_message_bytes, std::size_t max_partial_messages);

  /// The whole message once its last missing fragment arrives, else nullopt. Fragments that
  /// contradict earlier ones (another count), repeat or overflow the size are dropped.
  std::optional<std::vector<std::uint8_t>> add(const Frame& frame);

  std::size_t droppedFragments() const { return dropped_fragments_; }
  std::size_t droppedMessages() const { return dropped_messages_; }
  std::size_t partialMessages() const { return partial_.size(); }
  /// What the incomplete messages hold: their bytes and a slot per fragment.
  std::size_t partialBytes() const { return partial_bytes_; }

 private:
  struct Partial {
    std::vector<std::vector<std::uint8_t>> fragments;
    std::vector<bool> received;
    std::size_t missing = 0;
    std::size_t bytes = 0;  // received, and a slot per fragment
    std::uint64_t arrival = 0;
  };

  std::size_t max_message_bytes_;
  std::size_t max_partial_messages_;
  using PartialMap = std::map<std::pair<std::uint16_t, std::uint64_t>, Partial>;
  /// Drops the incomplete message that started longest ago, other than `keep`.
  void dropOldest(PartialMap::const_iterator keep);

  PartialMap partial_;
  std::uint64_t arrivals_ = 0;
  std::size_t partial_bytes_ = 0;
  std::size_t dropped_fragments_ = 0;
  std::size_t dropped_messages_ = 0;
};

}  // namespace ccir_mapping::core::transport
