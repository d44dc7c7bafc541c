// Rays, hits and footprints: what the simulated lidar and the world index exchange.
#pragma once

#include <Eigen/Core>

namespace ccir_mapping::core::simulation {

/// A ray from `origin` along the unit vector `direction`.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
};

/// Where a ray meets a surface: distance along the ray, outward unit normal, surface reflectivity.
struct Hit {
  double range = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  float reflectivity = 0.0F;
};

/// Axis-aligned rectangle in the xy plane.
struct Footprint {
  double x_min, y_min, x_max, y_max;
};

}  // namespace ccir_mapping::core::simulation
