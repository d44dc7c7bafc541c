#include "ccir_mapping/core/place_recognition/pose_gate.h"

#include <algorithm>
#include <cmath>

namespace ccir_mapping::core::place_recognition {

void PoseGate::addAnchor(const std::string& other, const GateAnchor& anchor) {
  auto& anchors = anchors_[other];
  anchors.push_back(anchor);
  while (anchors.size() > params_.max_anchors) anchors.pop_front();
}

const std::deque<GateAnchor>& PoseGate::anchors(const std::string& other) const {
  static const std::deque<GateAnchor> kNone;
  const auto it = anchors_.find(other);
  return it == anchors_.end() ? kNone : it->second;
}

double PoseGate::ratio(const GateAnchor& anchor, const GateKeyframe& own,
                       const GateKeyframe& other) const {
  const double own_path_m = own.path_m ? std::abs(*own.path_m - anchor.own_path_m) : 0.0;
  const double other_path_m = other.path_m && anchor.other_path_m
                                  ? std::abs(*other.path_m - *anchor.other_path_m)
                                  : (other.position - anchor.other_position).norm();
  const double allowance_m = std::min(
      params_.max_drift_m, kBaseAllowanceM + params_.drift_m_per_m * (own_path_m + other_path_m));
  const double distance_m = (own.position - anchor.other_in_own * other.position).norm();
  return distance_m / (params_.reach_m + allowance_m);
}

}  // namespace ccir_mapping::core::place_recognition
