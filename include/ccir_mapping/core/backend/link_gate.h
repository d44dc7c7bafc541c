// Which inter-robot loop closures may enter the team graph, per link (this robot and a teammate,
// or two teammates whose closures one of them found and shared): those the link's EM counts
// inliers of its transform (admit), and those the graph's switches accepted at the last solve
// (keep). The EM runs in full once a link's closures grew by kEmRerunGrowth since its last full
// run; between, that run's transform is re-checked against them (O(n)).
#pragma once

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::backend {

/// A robot's keyframe.
using KeyframeOf = std::pair<std::string, KeyframeId>;
/// A loop closure by its two keyframes, in a fixed order (either direction is the same loop).
using LoopKey = std::pair<KeyframeOf, KeyframeOf>;
/// Two robots whose closures one EM judges: (this robot, a teammate), or two teammates in name
/// order.
using Link = std::pair<std::string, std::string>;

class LinkGate {
 public:
  static constexpr double kEmRerunGrowth = 0.1;

  /// `em`'s max_time_s is replaced by each judge()'s.
  explicit LinkGate(const alignment::AlignmentParams& em) : em_(em) {}

  /// The EM of `link`'s closures `list`, or (with `recheck`, while they grew by less than
  /// kEmRerunGrowth since its last full run found a transform) a re-check of that transform;
  /// within max_time_s.
  alignment::AlignmentResult judge(const Link& link,
                                   const std::vector<alignment::AlignmentCandidate>& list,
                                   bool recheck, double max_time_s);
  /// A judging pass begins: what the last one admitted is forgotten.
  void clearAdmitted() { admitted_.clear(); }
  /// The inliers of `result` (keys[k] is the closure of its k-th candidate) may enter.
  void admit(const Link& link, const std::vector<LoopKey>& keys,
             const alignment::AlignmentResult& result);
  /// After a solve: the inter-robot closures its switches accepted, per link (replacing the
  /// last solve's).
  void keep(std::map<Link, std::set<LoopKey>> kept) { kept_ = std::move(kept); }
  /// The link's part of the graph is placed again: what the switches accepted no longer holds.
  void forgetKept(const Link& link) { kept_.erase(link); }
  std::size_t keptCount(const Link& link) const;
  bool admits(const Link& link, const LoopKey& key) const;

 private:
  alignment::AlignmentParams em_;
  std::map<Link, std::set<LoopKey>> admitted_;
  std::map<Link, std::set<LoopKey>> kept_;
  /// Per link: its closures at the last full EM, and that EM's result.
  std::map<Link, std::pair<std::size_t, alignment::AlignmentResult>> last_em_;
};

}  // namespace ccir_mapping::core::backend
