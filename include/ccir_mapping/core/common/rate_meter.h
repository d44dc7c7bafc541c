// Rates of running totals (bytes sent, say) per key, between one reading and the next.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>

namespace ccir_mapping::core {

class RateMeter {
 public:
  /// The growth of `total` per second since the previous reading of `key` (0 for the first, or
  /// when the clock has not advanced).
  double rate(const std::string& key, double at_s, std::uint64_t total) {
    auto [it, first] = last_.try_emplace(key, at_s, total);
    auto& [last_s, last_total] = it->second;
    const double rate =
        !first && at_s > last_s ? double(total - last_total) / (at_s - last_s) : 0.0;
    last_s = at_s;
    last_total = total;
    return rate;
  }

 private:
  std::map<std::string, std::pair<double, std::uint64_t>> last_;
};

}  // namespace ccir_mapping::core
