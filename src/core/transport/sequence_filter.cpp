#include "ccir_mapping/core/transport/sequence_filter.h"

namespace ccir_mapping::core::transport {

bool SequenceFilter::accept(const std::string& peer, std::uint16_t topic, std::uint64_t sequence) {
  std::uint64_t& last = last_[{peer, topic}];
  if (sequence <= last) {
    ++duplicates_;
    return false;
  }
  missing_ += sequence - last - 1;
  last = sequence;
  return true;
}

std::uint64_t SequenceFilter::delivered(const std::string& peer, std::uint16_t topic) const {
  const auto it = last_.find({peer, topic});
  return it == last_.end() ? 0 : it->second;
}

}  // namespace ccir_mapping::core::transport
