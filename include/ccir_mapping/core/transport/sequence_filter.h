// The receiving side of reliable topics: a message is delivered once, in order. A sequence
// already seen (resent after a reconnect) is a duplicate and dropped; a jump forward is a gap
// (the sender gave the message up), counted and accepted.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>

namespace ccir_mapping::core::transport {

class SequenceFilter {
 public:
  /// True when the message is new and should be delivered.
  bool accept(const std::string& peer, std::uint16_t topic, std::uint64_t sequence);
  /// Highest sequence delivered of a peer's topic (0 before any): what to acknowledge.
  std::uint64_t delivered(const std::string& peer, std::uint16_t topic) const;

  std::uint64_t duplicates() const { return duplicates_; }
  /// Messages missing in the gaps seen.
  std::uint64_t missing() const { return missing_; }

 private:
  std::map<std::pair<std::string, std::uint16_t>, std::uint64_t> last_;
  std::uint64_t duplicates_ = 0;
  std::uint64_t missing_ = 0;
};

}  // namespace ccir_mapping::core::transport
