// The sending side of reliable topics: every message sent stays here until the peer acknowledges
// its sequence number (cumulatively, per topic), and what is unacknowledged when a link drops is
// sent again after the reconnect, in order. Bounded in bytes: beyond it the oldest message is
// given up and counted (the receiver then sees a gap).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <vector>

namespace ccir_mapping::core::transport {

struct PendingMessage {
  std::uint16_t topic = 0;
  std::uint64_t sequence = 0;
  std::vector<std::uint8_t> bytes;
};

class ReliableOutbox {
 public:
  explicit ReliableOutbox(std::size_t max_unacknowledged_bytes);

  /// A message handed to the link (sequences increase per topic).
  void sent(std::uint16_t topic, std::uint64_t sequence, std::vector<std::uint8_t> bytes);
  /// The peer has every message of `topic` up to `sequence`.
  void acknowledge(std::uint16_t topic, std::uint64_t sequence);
  /// What to send again after a reconnect: per topic, in sequence order.
  std::vector<PendingMessage> unacknowledged() const;
  /// Whether a message still waits for its acknowledgement.
  bool pending(std::uint16_t topic, std::uint64_t sequence) const;

  std::size_t bytes() const { return bytes_; }
  std::size_t messages() const;
  /// What one topic holds: messages and their bytes.
  std::size_t messages(std::uint16_t topic) const;
  std::size_t bytes(std::uint16_t topic) const;
  std::uint64_t givenUp() const { return given_up_; }

 private:
  std::size_t max_bytes_;
  std::map<std::uint16_t, std::deque<PendingMessage>> pending_;
  std::size_t bytes_ = 0;
  std::uint64_t given_up_ = 0;
};

}  // namespace ccir_mapping::core::transport
