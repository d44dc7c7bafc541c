// A vertical wall segment of a simulated world.
#pragma once

#include <Eigen/Core>

#include "ccir_mapping/core/simulation/ray.h"

namespace ccir_mapping::core::simulation {

/// A vertical quad over the segment from `a` to `b`, seen from both sides (cave walls).
struct Wall {
  Eigen::Vector2d a;
  Eigen::Vector2d b;
  double z_min = 0.0;
  double z_max = 0.0;
  float reflectivity = 0.5F;

  bool intersect(const Ray& ray, double max_range, Hit* hit) const;
  Footprint footprint() const;
};

}  // namespace ccir_mapping::core::simulation
