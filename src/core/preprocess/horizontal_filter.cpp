#include "ccir_mapping/core/preprocess/horizontal_filter.h"

#include <cmath>

namespace ccir_mapping::core::preprocess {

std::optional<HorizontalFilter> parseHorizontalFilter(std::string_view text) {
  if (text == "none") return HorizontalFilter::kNone;
  if (text == "ground") return HorizontalFilter::kGround;
  if (text == "ceiling") return HorizontalFilter::kCeiling;
  if (text == "both") return HorizontalFilter::kBoth;
  return std::nullopt;
}

const char* toString(HorizontalFilter filter) {
  switch (filter) {
    case HorizontalFilter::kNone:
      return "none";
    case HorizontalFilter::kGround:
      return "ground";
    case HorizontalFilter::kCeiling:
      return "ceiling";
    default:
      return "both";
  }
}

bool dropsAsHorizontal(HorizontalFilter filter, double max_normal_up,
                       const Eigen::Vector3f& position, const Eigen::Vector3f& normal,
                       const Eigen::Vector3f& up) {
  if (filter == HorizontalFilter::kNone || std::abs(normal.dot(up)) <= max_normal_up) return false;
  const bool below = position.dot(up) < 0.0F;
  return filter == HorizontalFilter::kBoth || (below == (filter == HorizontalFilter::kGround));
}

}  // namespace ccir_mapping::core::preprocess
