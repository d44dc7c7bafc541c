// A simulated environment: upright solids between a floor and a ceiling, with a spatial index
// for ray casting and the road map robots drive on.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/simulation/box.h"
#include "ccir_mapping/core/simulation/cylinder.h"
#include "ccir_mapping/core/simulation/ray.h"
#include "ccir_mapping/core/simulation/road_map.h"
#include "ccir_mapping/core/simulation/wall.h"

namespace ccir_mapping::core::simulation {

/// Ray casting goes through a uniform grid over the floor plan (2D DDA, Amanatides & Woo) and
/// tests only the solids listed in the cells the ray crosses, nearest cells first. Written here
/// because none of our libraries casts against analytic solids: OctoMap would voxelise the world
/// and lose the exact distances the sensor tests check, MRPT's scene ray tracer tests every object.
class World {
 public:
  World(std::string kind, double floor_z, double ceiling_z);

  void add(const Box& box);
  void add(const Cylinder& cylinder);
  void add(const Wall& wall);
  RoadMap& roadMap() { return road_map_; }

  /// Builds the spatial index; required after the last add() and before castRay().
  void buildIndex(double cell_size_m);

  /// Nearest surface (solids, floor, ceiling) with 0 < range < max_range.
  std::optional<Hit> castRay(const Ray& ray, double max_range) const;
  /// The same by testing every solid: the reference for tests and the benchmark baseline.
  std::optional<Hit> castRayBruteForce(const Ray& ray, double max_range) const;

  const std::string& kind() const { return kind_; }
  double floorZ() const { return floor_z_; }
  double ceilingZ() const { return ceiling_z_; }
  /// xy extent of all solids.
  const Footprint& bounds() const { return bounds_; }
  const RoadMap& roadMap() const { return road_map_; }
  const std::vector<Box>& boxes() const { return boxes_; }
  const std::vector<Cylinder>& cylinders() const { return cylinders_; }
  const std::vector<Wall>& walls() const { return walls_; }

  static constexpr float kFloorReflectivity = 0.25F;
  static constexpr float kCeilingReflectivity = 0.35F;

 private:
  void extendBounds(const Footprint& footprint);
  /// Tests the solid encoded in `item` (kind in the top two bits, index below).
  bool intersectItem(std::uint32_t item, const Ray& ray, double max_range, Hit* hit) const;
  /// Floor or ceiling, whichever the ray meets, if nearer than max_range.
  std::optional<Hit> castPlanes(const Ray& ray, double max_range) const;

  std::string kind_;
  double floor_z_;
  double ceiling_z_;
  Footprint bounds_;
  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Wall> walls_;
  RoadMap road_map_;

  // Grid index: cell (ix, iy) lists items cell_items_[cell_start_[c] .. cell_start_[c + 1]).
  double cell_size_m_ = 0.0;
  double grid_x0_ = 0.0;
  double grid_y0_ = 0.0;
  int grid_nx_ = 0;
  int grid_ny_ = 0;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> cell_items_;
};

}  // namespace ccir_mapping::core::simulation
