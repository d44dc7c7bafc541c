// The solids a simulated world is made of. Each stands upright (rotated about z only), which is
// what room-and-pillar mines, extruded floor plans and caves need, and keeps ray tests cheap.
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

/// A solid upright cylinder (columns).
struct Cylinder {
  Eigen::Vector2d center;
  double radius = 0.0;
  double z_min = 0.0;
  double z_max = 0.0;
  float reflectivity = 0.5F;

  bool intersect(const Ray& ray, double max_range, Hit* hit) const;
  Footprint footprint() const;
};

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
