// Scan Context's place search (Kim & Kim, IROS 2018): the places whose ring keys are nearest the
// query's are compared in full, at their best yaw shift, nearest first.
#pragma once

#include <functional>
#include <vector>

#include "ccir_mapping/core/place_recognition/scan_context.h"

namespace ccir_mapping::core::place_recognition {

class ScanContextIndex {
 public:
  struct Match {
    std::size_t index = 0;
    ScanContextDistance distance;
  };

  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit ScanContextIndex(const ScanContextParams& params);

  /// Place size(), in the order added.
  void add(ScanContext context);
  std::size_t size() const { return places_.size(); }

  /// Of the places `eligible` accepts, the ring_key_candidates nearest the query's ring key,
  /// compared in full: nearest first.
  std::vector<Match> query(const ScanContext& query,
                           const std::function<bool(std::size_t)>& eligible) const;

 private:
  ScanContextParams params_;
  std::vector<ScanContext> places_;
};

}  // namespace ccir_mapping::core::place_recognition
