#include "ccir_mapping/core/transport/reliable_outbox.h"

#include <algorithm>

namespace ccir_mapping::core::transport {

ReliableOutbox::ReliableOutbox(std::size_t max_unacknowledged_bytes)
    : max_bytes_(max_unacknowledged_bytes) {}

void ReliableOutbox::sent(std::uint16_t topic, std::uint64_t sequence,
                          std::vector<std::uint8_t> bytes) {
  bytes_ += bytes.size();
  pending_[topic].push_back({topic, sequence, std::move(bytes)});
  // Over the bound: give up the oldest messages of the topic holding the most bytes.
  while (bytes_ > max_bytes_) {
    auto largest = std::max_element(pending_.begin(), pending_.end(), [](auto& a, auto& b) {
      return a.second.size() < b.second.size();
    });
    if (largest->second.empty()) break;
    bytes_ -= largest->second.front().bytes.size();
    largest->second.pop_front();
    ++given_up_;
  }
}

void ReliableOutbox::acknowledge(std::uint16_t topic, std::uint64_t sequence) {
  const auto it = pending_.find(topic);
  if (it == pending_.end()) return;
  auto& queue = it->second;
  while (!queue.empty() && queue.front().sequence <= sequence) {
    bytes_ -= queue.front().bytes.size();
    queue.pop_front();
  }
}

std::vector<PendingMessage> ReliableOutbox::unacknowledged() const {
  std::vector<PendingMessage> all;
  for (const auto& [topic, queue] : pending_) all.insert(all.end(), queue.begin(), queue.end());
  return all;
}

bool ReliableOutbox::pending(std::uint16_t topic, std::uint64_t sequence) const {
  const auto it = pending_.find(topic);
  return it != pending_.end() &&
         std::any_of(it->second.begin(), it->second.end(),
                     [sequence](const PendingMessage& m) { return m.sequence == sequence; });
}

std::size_t ReliableOutbox::messages() const {
  std::size_t n = 0;
  for (const auto& [topic, queue] : pending_) n += queue.size();
  return n;
}

std::size_t ReliableOutbox::messages(std::uint16_t topic) const {
  const auto it = pending_.find(topic);
  return it == pending_.end() ? 0 : it->second.size();
}

std::size_t ReliableOutbox::bytes(std::uint16_t topic) const {
  const auto it = pending_.find(topic);
  std::size_t n = 0;
  if (it != pending_.end()) {
    for (const auto& m : it->second) n += m.bytes.size();
  }
  return n;
}

}  // namespace ccir_mapping::core::transport
