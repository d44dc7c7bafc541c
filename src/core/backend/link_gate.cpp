#include "ccir_mapping/core/backend/link_gate.h"

namespace ccir_mapping::core::backend {

alignment::AlignmentResult LinkGate::judge(const Link& link,
                                           const std::vector<alignment::AlignmentCandidate>& list,
                                           bool recheck, double max_time_s) {
  alignment::AlignmentParams em = em_;
  em.max_time_s = max_time_s;
  alignment::AlignmentResult result;
  const auto last = last_em_.find(link);
  if (recheck && last != last_em_.end() && last->second.second.found &&
      static_cast<double>(list.size()) < (1.0 + kEmRerunGrowth) * last->second.first) {
    result = alignment::checkFrameTransform(list, em, last->second.second);
  }
  if (!result.found) {
    result = alignment::estimateFrameTransform(list, em);
    last_em_[link] = {list.size(), result};
  }
  return result;
}

void LinkGate::admit(const Link& link, const std::vector<LoopKey>& keys,
                     const alignment::AlignmentResult& result) {
  for (std::size_t k = 0; result.found && k < keys.size(); ++k) {
    if (result.inliers[k]) admitted_[link].insert(keys[k]);
  }
}

std::size_t LinkGate::keptCount(const Link& link) const {
  const auto it = kept_.find(link);
  return it == kept_.end() ? 0 : it->second.size();
}

bool LinkGate::admits(const Link& link, const LoopKey& key) const {
  for (const auto* sets : {&admitted_, &kept_}) {
    const auto it = sets->find(link);
    if (it != sets->end() && it->second.count(key)) return true;
  }
  return false;
}

}  // namespace ccir_mapping::core::backend
