// A solid upright box of a simulated world.
#pragma once

#include <Eigen/Core>

#include "ccir_mapping/core/simulation/ray.h"

namespace ccir_mapping::core::simulation {

/// A solid box rotated by `yaw` about the vertical through its centre (pillars, rubble, clutter,
/// building walls).
struct Box {
  Eigen::Vector2d center;
  Eigen::Vector2d half_size;
  /// Unit vector of the box's local x axis in the world (cos yaw, sin yaw): kept instead of the
  /// yaw so that a ray test needs no trigonometry.
  Eigen::Vector2d axis = Eigen::Vector2d::UnitX();
  double z_min = 0.0;
  double z_max = 0.0;
  float reflectivity = 0.5F;

  static Box upright(const Eigen::Vector2d& center, const Eigen::Vector2d& size, double yaw,
                     double z_min, double z_max, float reflectivity);

  /// Nearest entry of the ray into the box with 0 < range < max_range.
  bool intersect(const Ray& ray, double max_range, Hit* hit) const;
  Footprint footprint() const;
};

}  // namespace ccir_mapping::core::simulation
