// Ray tests of the solids worlds are made of (box.h, cylinder.h, wall.h).
#include "ccir_mapping/core/simulation/box.h"
#include "ccir_mapping/core/simulation/cylinder.h"
#include "ccir_mapping/core/simulation/wall.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ccir_mapping::core::simulation {
namespace {

// A ray starting on a surface must not hit that surface again.
constexpr double kMinRange = 1e-9;

double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}

}  // namespace

Box Box::upright(const Eigen::Vector2d& center, const Eigen::Vector2d& size, double yaw,
                 double z_min, double z_max, float reflectivity) {
  Box box;
  box.center = center;
  box.half_size = 0.5 * size;
  box.axis = Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
  box.z_min = z_min;
  box.z_max = z_max;
  box.reflectivity = reflectivity;
  return box;
}

bool Box::intersect(const Ray& ray, double max_range, Hit* hit) const {
  // Slab test in the box frame.
  const Eigen::Vector2d offset = ray.origin.head<2>() - center;
  const double origin_local[3] = {axis.dot(offset), cross(axis, offset),
                                  ray.origin.z() - 0.5 * (z_min + z_max)};
  const Eigen::Vector2d dir_xy = ray.direction.head<2>();
  const double dir_local[3] = {axis.dot(dir_xy), cross(axis, dir_xy), ray.direction.z()};
  const double half[3] = {half_size.x(), half_size.y(), 0.5 * (z_max - z_min)};

  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int near_axis = -1;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(dir_local[i]) < 1e-12) {
      if (std::abs(origin_local[i]) > half[i]) return false;
      continue;
    }
    double t1 = (-half[i] - origin_local[i]) / dir_local[i];
    double t2 = (half[i] - origin_local[i]) / dir_local[i];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > t_near) {
      t_near = t1;
      near_axis = i;
    }
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return false;
  }
  // An origin inside the box (t_near < 0) sees nothing: sensors are never inside solids.
  if (near_axis < 0 || t_near <= kMinRange || t_near >= max_range) return false;

  const double sign = dir_local[near_axis] > 0.0 ? -1.0 : 1.0;
  hit->range = t_near;
  if (near_axis == 0) {
    hit->normal << sign * axis.x(), sign * axis.y(), 0.0;
  } else if (near_axis == 1) {
    hit->normal << -sign * axis.y(), sign * axis.x(), 0.0;
  } else {
    hit->normal << 0.0, 0.0, sign;
  }
  hit->reflectivity = reflectivity;
  return true;
}

Footprint Box::footprint() const {
  const double ex = std::abs(axis.x()) * half_size.x() + std::abs(axis.y()) * half_size.y();
  const double ey = std::abs(axis.y()) * half_size.x() + std::abs(axis.x()) * half_size.y();
  return {center.x() - ex, center.y() - ey, center.x() + ex, center.y() + ey};
}

bool Cylinder::intersect(const Ray& ray, double max_range, Hit* hit) const {
  const Eigen::Vector2d offset = ray.origin.head<2>() - center;
  const Eigen::Vector2d dir_xy = ray.direction.head<2>();
  double best = max_range;
  bool found = false;

  const double a = dir_xy.squaredNorm();
  if (a > 1e-12) {
    const double b = offset.dot(dir_xy);
    const double c = offset.squaredNorm() - radius * radius;
    const double discriminant = b * b - a * c;
    if (discriminant >= 0.0) {
      const double t = (-b - std::sqrt(discriminant)) / a;
      const double z = ray.origin.z() + t * ray.direction.z();
      if (t > kMinRange && t < best && z >= z_min && z <= z_max) {
        best = t;
        found = true;
        const Eigen::Vector2d n = (offset + t * dir_xy) / radius;
        hit->normal << n.x(), n.y(), 0.0;
      }
    }
  }
  const double dz = ray.direction.z();
  if (std::abs(dz) > 1e-12) {
    const double plane = dz < 0.0 ? z_max : z_min;
    const double t = (plane - ray.origin.z()) / dz;
    if (t > kMinRange && t < best && (offset + t * dir_xy).squaredNorm() <= radius * radius) {
      best = t;
      found = true;
      hit->normal << 0.0, 0.0, dz < 0.0 ? 1.0 : -1.0;
    }
  }
  if (!found) return false;
  hit->range = best;
  hit->reflectivity = reflectivity;
  return true;
}

Footprint Cylinder::footprint() const {
  return {center.x() - radius, center.y() - radius, center.x() + radius, center.y() + radius};
}

bool Wall::intersect(const Ray& ray, double max_range, Hit* hit) const {
  const Eigen::Vector2d edge = b - a;
  const Eigen::Vector2d dir_xy = ray.direction.head<2>();
  const double denominator = cross(dir_xy, edge);
  if (std::abs(denominator) < 1e-12) return false;  // parallel to the wall
  const Eigen::Vector2d w = a - ray.origin.head<2>();
  const double t = cross(w, edge) / denominator;
  if (t <= kMinRange || t >= max_range) return false;
  // Tolerance so that a ray through the vertex two walls share cannot slip between them.
  const double s = cross(w, dir_xy) / denominator;
  if (s < -1e-9 || s > 1.0 + 1e-9) return false;
  const double z = ray.origin.z() + t * ray.direction.z();
  if (z < z_min || z > z_max) return false;

  Eigen::Vector2d n(edge.y(), -edge.x());
  n.normalize();
  if (n.dot(dir_xy) > 0.0) n = -n;
  hit->range = t;
  hit->normal << n.x(), n.y(), 0.0;
  hit->reflectivity = reflectivity;
  return true;
}

Footprint Wall::footprint() const {
  return {std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()),
          std::max(a.y(), b.y())};
}

}  // namespace ccir_mapping::core::simulation
