// Candidate pairs found without a pose prior (a teammate no closure has anchored yet, or places
// outside every gate), verified within a budget: each query's best first, at most a rate per
// second of mission time, none after waiting longer than a horizon. This bounds what an aliased
// mine costs: each query there ranks dozens of look-alike places.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::place_recognition {

class VerificationQueue {
 public:
  /// One pair: this robot's keyframe and a teammate's kept scan, as ranked by the query (0:
  /// its best).
  struct Entry {
    int rank = 0;
    double score = 0.0;
    Stamp queued = 0;
    KeyframeId own = 0;
    std::string teammate;
    KeyframeId teammate_keyframe = 0;
    double new_place_probability = -1.0;
    int correspondences = 0;
  };

  /// per_s: verifications per second of mission time (> 0); horizon_s: longest wait.
  VerificationQueue(double per_s, double horizon_s);

  void push(Entry entry);
  /// The entries the budget accrued up to `now` pays for, best first; entries queued more
  /// than the horizon before `now` are dropped (counted in expired()).
  std::vector<Entry> release(Stamp now);

  std::size_t size() const { return entries_.size(); }
  std::size_t expired() const { return expired_; }

 private:
  double per_s_;
  Stamp horizon_;
  std::vector<Entry> entries_;
  double tokens_ = 0.0;
  Stamp last_ = 0;
  bool started_ = false;
  std::size_t expired_ = 0;
};

}  // namespace ccir_mapping::core::place_recognition
