#include "ccir_mapping/core/transport/message_fragments.h"

#include <algorithm>
#include <stdexcept>

namespace ccir_mapping::core::transport {

std::vector<Frame> fragmentMessage(std::uint16_t topic, std::uint64_t sequence,
                                   const std::vector<std::uint8_t>& message,
                                   std::size_t fragment_bytes, std::uint8_t flags) {
  if (fragment_bytes == 0) throw std::invalid_argument("fragmentMessage: fragment_bytes is 0");
  const std::size_t count =
      std::max<std::size_t>(1, (message.size() + fragment_bytes - 1) / fragment_bytes);
  if (count > 0xffff) throw std::invalid_argument("fragmentMessage: more than 65535 fragments");
  std::vector<Frame> frames(count);
  for (std::size_t i = 0; i < count; ++i) {
    Frame& f = frames[i];
    f.type = FrameType::kData;
    f.flags = flags;
    f.topic = topic;
    f.sequence = sequence;
    f.fragment = static_cast<std::uint16_t>(i);
    f.fragments = static_cast<std::uint16_t>(count);
    const std::size_t begin = i * fragment_bytes;
    const std::size_t end = std::min(message.size(), begin + fragment_bytes);
    f.payload.assign(message.begin() + static_cast<std::ptrdiff_t>(begin),
                     message.begin() + static_cast<std::ptrdiff_t>(end));
  }
  return frames;
}

namespace {
// What an incomplete message's slot for one fragment costs: the vector that will hold it, its
// allocation's overhead and the received flag.
constexpr std::size_t kSlotBytes = sizeof(std::vector<std::uint8_t>) + 40;
}  // namespace

Reassembler::Reassembler(std::size_t max_message_bytes, std::size_t max_partial_messages)
    : max_message_bytes_(max_message_bytes),
      max_partial_messages_(std::max<std::size_t>(1, max_partial_messages)) {}

std::optional<std::vector<std::uint8_t>> Reassembler::add(const Frame& frame) {
  if (frame.fragments == 1 && frame.fragment == 0) {
    if (frame.payload.size() > max_message_bytes_) {
      ++dropped_fragments_;
      return std::nullopt;
    }
    return frame.payload;
  }
  const auto key = std::make_pair(frame.topic, frame.sequence);
  auto it = partial_.find(key);
  if (it == partial_.end()) {
    if (partial_.size() >= max_partial_messages_) dropOldest(partial_.end());
    Partial p;
    p.fragments.resize(frame.fragments);
    p.received.assign(frame.fragments, false);
    p.missing = frame.fragments;
    p.arrival = arrivals_++;
    // Each announced fragment costs a slot before any byte of it came: counted with the bytes,
    // so that thousands of tiny fragments are bounded too.
    p.bytes = frame.fragments * kSlotBytes;
    partial_bytes_ += p.bytes;
    it = partial_.emplace(key, std::move(p)).first;
    while (partial_bytes_ > 2 * max_message_bytes_ && partial_.size() > 1) dropOldest(it);
  }
  Partial& p = it->second;
  if (p.fragments.size() != frame.fragments || frame.fragment >= frame.fragments ||
      p.received[frame.fragment] ||
      p.bytes + frame.payload.size() > max_message_bytes_ + p.fragments.size() * kSlotBytes) {
    ++dropped_fragments_;
    return std::nullopt;
  }
  p.received[frame.fragment] = true;
  p.bytes += frame.payload.size();
  partial_bytes_ += frame.payload.size();
  p.fragments[frame.fragment] = frame.payload;
  // Over the joint bound: give up the oldest other incomplete messages (this one holds at most
  // max_message_bytes, so the others hold the excess).
  while (partial_bytes_ > 2 * max_message_bytes_ && partial_.size() > 1) dropOldest(it);
  if (--p.missing > 0) return std::nullopt;
  std::vector<std::uint8_t> message;
  message.reserve(p.bytes - p.fragments.size() * kSlotBytes);
  for (const auto& f : p.fragments) message.insert(message.end(), f.begin(), f.end());
  partial_bytes_ -= p.bytes;
  partial_.erase(it);
  return message;
}

void Reassembler::dropOldest(PartialMap::const_iterator keep) {
  auto oldest = partial_.end();
  for (auto i = partial_.begin(); i != partial_.end(); ++i) {
    if (i != keep && (oldest == partial_.end() || i->second.arrival < oldest->second.arrival)) {
      oldest = i;
    }
  }
  if (oldest == partial_.end()) return;
  partial_bytes_ -= oldest->second.bytes;
  partial_.erase(oldest);
  ++dropped_messages_;
}

}  // namespace ccir_mapping::core::transport
