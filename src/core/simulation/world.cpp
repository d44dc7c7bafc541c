#include "ccir_mapping/core/simulation/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ccir_mapping::core::simulation {
namespace {

constexpr std::uint32_t kBoxItem = 0U << 30;
constexpr std::uint32_t kCylinderItem = 1U << 30;
constexpr std::uint32_t kWallItem = 2U << 30;
constexpr std::uint32_t kKindMask = 3U << 30;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

}  // namespace

World::World(std::string kind, double floor_z, double ceiling_z)
    : kind_(std::move(kind)),
      floor_z_(floor_z),
      ceiling_z_(ceiling_z),
      bounds_{kInfinity, kInfinity, -kInfinity, -kInfinity} {
  if (!(ceiling_z > floor_z)) throw std::invalid_argument("World: ceiling must be above floor");
}

void World::extendBounds(const Footprint& f) {
  bounds_.x_min = std::min(bounds_.x_min, f.x_min);
  bounds_.y_min = std::min(bounds_.y_min, f.y_min);
  bounds_.x_max = std::max(bounds_.x_max, f.x_max);
  bounds_.y_max = std::max(bounds_.y_max, f.y_max);
}

void World::add(const Box& box) {
  boxes_.push_back(box);
  extendBounds(box.footprint());
  cell_start_.clear();
}

void World::add(const Cylinder& cylinder) {
  cylinders_.push_back(cylinder);
  extendBounds(cylinder.footprint());
  cell_start_.clear();
}

void World::add(const Wall& wall) {
  walls_.push_back(wall);
  extendBounds(wall.footprint());
  cell_start_.clear();
}

void World::buildIndex(double cell_size_m) {
  if (!(cell_size_m > 0.0)) throw std::invalid_argument("World::buildIndex: cell size <= 0");
  if (boxes_.size() + cylinders_.size() + walls_.size() >= (1U << 30)) {
    throw std::length_error("World::buildIndex: too many solids");
  }
  cell_size_m_ = cell_size_m;
  const bool empty = !(bounds_.x_max >= bounds_.x_min);
  // One spare cell around the solids so that footprints never touch the grid's edge.
  grid_x0_ = (empty ? 0.0 : bounds_.x_min) - cell_size_m;
  grid_y0_ = (empty ? 0.0 : bounds_.y_min) - cell_size_m;
  grid_nx_ = empty ? 1 : static_cast<int>(std::ceil((bounds_.x_max - grid_x0_) / cell_size_m)) + 1;
  grid_ny_ = empty ? 1 : static_cast<int>(std::ceil((bounds_.y_max - grid_y0_) / cell_size_m)) + 1;

  std::vector<std::vector<std::uint32_t>> cells(static_cast<size_t>(grid_nx_) * grid_ny_);
  auto insert = [&](const Footprint& f, std::uint32_t item) {
    const int x0 =
        std::clamp(static_cast<int>((f.x_min - grid_x0_) / cell_size_m), 0, grid_nx_ - 1);
    const int x1 =
        std::clamp(static_cast<int>((f.x_max - grid_x0_) / cell_size_m), 0, grid_nx_ - 1);
    const int y0 =
        std::clamp(static_cast<int>((f.y_min - grid_y0_) / cell_size_m), 0, grid_ny_ - 1);
    const int y1 =
        std::clamp(static_cast<int>((f.y_max - grid_y0_) / cell_size_m), 0, grid_ny_ - 1);
    for (int iy = y0; iy <= y1; ++iy) {
      for (int ix = x0; ix <= x1; ++ix)
        cells[static_cast<size_t>(iy) * grid_nx_ + ix].push_back(item);
    }
  };
  for (std::uint32_t i = 0; i < boxes_.size(); ++i) insert(boxes_[i].footprint(), kBoxItem | i);
  for (std::uint32_t i = 0; i < cylinders_.size(); ++i) {
    insert(cylinders_[i].footprint(), kCylinderItem | i);
  }
  for (std::uint32_t i = 0; i < walls_.size(); ++i) insert(walls_[i].footprint(), kWallItem | i);

  cell_start_.assign(cells.size() + 1, 0);
  cell_items_.clear();
  for (size_t c = 0; c < cells.size(); ++c) {
    cell_start_[c] = static_cast<std::uint32_t>(cell_items_.size());
    cell_items_.insert(cell_items_.end(), cells[c].begin(), cells[c].end());
  }
  cell_start_.back() = static_cast<std::uint32_t>(cell_items_.size());
}

bool World::intersectItem(std::uint32_t item, const Ray& ray, double max_range, Hit* hit) const {
  const std::uint32_t index = item & ~kKindMask;
  switch (item & kKindMask) {
    case kBoxItem:
      return boxes_[index].intersect(ray, max_range, hit);
    case kCylinderItem:
      return cylinders_[index].intersect(ray, max_range, hit);
    default:
      return walls_[index].intersect(ray, max_range, hit);
  }
}

std::optional<Hit> World::castPlanes(const Ray& ray, double max_range) const {
  const double dz = ray.direction.z();
  Hit hit;
  if (dz < -1e-12) {
    hit.range = (floor_z_ - ray.origin.z()) / dz;
    hit.normal = Eigen::Vector3d::UnitZ();
    hit.reflectivity = kFloorReflectivity;
  } else if (dz > 1e-12) {
    hit.range = (ceiling_z_ - ray.origin.z()) / dz;
    hit.normal = -Eigen::Vector3d::UnitZ();
    hit.reflectivity = kCeilingReflectivity;
  } else {
    return std::nullopt;
  }
  if (hit.range <= 0.0 || hit.range >= max_range) return std::nullopt;
  return hit;
}

std::optional<Hit> World::castRayBruteForce(const Ray& ray, double max_range) const {
  std::optional<Hit> best = castPlanes(ray, max_range);
  double limit = best ? best->range : max_range;
  Hit hit;
  auto test = [&](const auto& solids) {
    for (const auto& solid : solids) {
      if (solid.intersect(ray, limit, &hit)) {
        best = hit;
        limit = hit.range;
      }
    }
  };
  test(boxes_);
  test(cylinders_);
  test(walls_);
  return best;
}

std::optional<Hit> World::castRay(const Ray& ray, double max_range) const {
  if (cell_start_.empty()) throw std::logic_error("World::castRay before buildIndex");
  std::optional<Hit> best = castPlanes(ray, max_range);
  double limit = best ? best->range : max_range;

  const double ox = ray.origin.x() - grid_x0_;
  const double oy = ray.origin.y() - grid_y0_;
  const double dx = ray.direction.x();
  const double dy = ray.direction.y();
  const double width = grid_nx_ * cell_size_m_;
  const double height = grid_ny_ * cell_size_m_;

  // Where the ray enters the grid (0 when it starts inside).
  double t_enter = 0.0;
  double t_leave = limit;
  for (const auto& [o, d, size] : {std::tuple{ox, dx, width}, std::tuple{oy, dy, height}}) {
    if (std::abs(d) < 1e-15) {
      if (o < 0.0 || o > size) return best;
      continue;
    }
    double t0 = -o / d;
    double t1 = (size - o) / d;
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_leave = std::min(t_leave, t1);
  }
  if (t_enter > t_leave) return best;

  int ix = std::clamp(static_cast<int>((ox + t_enter * dx) / cell_size_m_), 0, grid_nx_ - 1);
  int iy = std::clamp(static_cast<int>((oy + t_enter * dy) / cell_size_m_), 0, grid_ny_ - 1);
  const int step_x = dx > 0.0 ? 1 : -1;
  const int step_y = dy > 0.0 ? 1 : -1;
  const double delta_x = std::abs(dx) > 1e-15 ? cell_size_m_ / std::abs(dx) : kInfinity;
  const double delta_y = std::abs(dy) > 1e-15 ? cell_size_m_ / std::abs(dy) : kInfinity;
  double next_x = std::abs(dx) > 1e-15 ? ((ix + (dx > 0.0)) * cell_size_m_ - ox) / dx : kInfinity;
  double next_y = std::abs(dy) > 1e-15 ? ((iy + (dy > 0.0)) * cell_size_m_ - oy) / dy : kInfinity;

  Hit hit;
  while (true) {
    const size_t cell = static_cast<size_t>(iy) * grid_nx_ + ix;
    for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
      if (intersectItem(cell_items_[k], ray, limit, &hit)) {
        best = hit;
        limit = hit.range;
      }
    }
    // A hit inside this cell cannot be beaten by anything in a later cell.
    if (limit <= std::min(next_x, next_y)) break;
    if (next_x < next_y) {
      ix += step_x;
      next_x += delta_x;
      if (ix < 0 || ix >= grid_nx_) break;
    } else {
      iy += step_y;
      next_y += delta_y;
      if (iy < 0 || iy >= grid_ny_) break;
    }
  }
  return best;
}

}  // namespace ccir_mapping::core::simulation
