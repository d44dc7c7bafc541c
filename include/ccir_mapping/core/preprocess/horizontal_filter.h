// The thesis's degenerate-normal filter (section 4.1): in tunnels and mines, once ground and
// ceiling are set aside, a well-estimated normal is nearly horizontal, so a point whose normal
// has a large component along "up" lies on the ground, the ceiling, or has a normal degenerated
// by the sparse rings.
#pragma once

#include <optional>
#include <string_view>

#include <Eigen/Core>

namespace ccir_mapping::core::preprocess {

/// Which of those points to drop: below the sensor (ground), above it (ceiling), both (the
/// thesis) or none.
enum class HorizontalFilter { kNone, kGround, kCeiling, kBoth };
constexpr std::string_view kHorizontalFilterChoices = "none | ground | ceiling | both";
std::optional<HorizontalFilter> parseHorizontalFilter(std::string_view text);
const char* toString(HorizontalFilter filter);

/// True when `filter` drops the point at `position` (sensor frame) with unit `normal`:
/// |normal . up| > max_normal_up and the point is on a side `filter` names.
bool dropsAsHorizontal(HorizontalFilter filter, double max_normal_up,
                       const Eigen::Vector3f& position, const Eigen::Vector3f& normal,
                       const Eigen::Vector3f& up);

}  // namespace ccir_mapping::core::preprocess
