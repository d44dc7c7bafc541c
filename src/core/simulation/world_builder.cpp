#include "ccir_mapping/core/simulation/world_builder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Solids reach a little past floor and ceiling so that no beam slips along a seam.
constexpr double kSeamM = 0.05;
constexpr double kOuterWallM = 0.5;

using Rng = std::mt19937_64;
using Eigen::Vector2d;

double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

/// x drawn before y: several draws in one argument list would be drawn in an unspecified order.
Vector2d uniform2(Rng& rng, const Vector2d& lo, const Vector2d& hi) {
  const double x = uniform(rng, lo.x(), hi.x());
  return {x, uniform(rng, lo.y(), hi.y())};
}

/// Four boxes enclosing [0, x] x [0, y] from the outside.
void addOuterWalls(World& world, double x, double y, double height) {
  const double t = kOuterWallM;
  const double z0 = -kSeamM;
  const double z1 = height + kSeamM;
  world.add(Box::upright({0.5 * x, -0.5 * t}, {x + 2 * t, t}, 0.0, z0, z1, 0.6F));
  world.add(Box::upright({0.5 * x, y + 0.5 * t}, {x + 2 * t, t}, 0.0, z0, z1, 0.6F));
  world.add(Box::upright({-0.5 * t, 0.5 * y}, {t, y + 2 * t}, 0.0, z0, z1, 0.6F));
  world.add(Box::upright({x + 0.5 * t, 0.5 * y}, {t, y + 2 * t}, 0.0, z0, z1, 0.6F));
}

// --- mine ---------------------------------------------------------------------------------------

World buildMine(const WorldParams& p, Rng& rng) {
  const double w = p.mine_pillar_size_m;
  const double d = p.mine_drift_width_m;
  const double h = p.mine_height_m;
  const double pitch = w + d;
  const double size_x = p.mine_pillars_x * pitch + d;
  const double size_y = p.mine_pillars_y * pitch + d;
  const double max_yaw = p.mine_rotation_jitter_deg * kPi / 180.0;
  World world("mine", 0.0, h);
  addOuterWalls(world, size_x, size_y, h);

  std::bernoulli_distribution has_rubble(p.mine_rubble_per_pillar);
  for (int i = 0; i < p.mine_pillars_x; ++i) {
    for (int j = 0; j < p.mine_pillars_y; ++j) {
      const Vector2d center(d + 0.5 * w + i * pitch, d + 0.5 * w + j * pitch);
      const double jitter = p.mine_size_jitter_m;
      const Vector2d size =
          uniform2(rng, Vector2d::Constant(w - jitter), Vector2d::Constant(w + jitter));
      const double yaw = uniform(rng, -max_yaw, max_yaw);
      const auto reflectivity = static_cast<float>(uniform(rng, 0.45, 0.55));
      world.add(Box::upright(center, size, yaw, -kSeamM, h + kSeamM, reflectivity));
      if (!has_rubble(rng)) continue;

      // A rubble box against one face, in the pillar's frame; it reaches at most
      // kMineRubbleDepthMaxM into the drift (yaw jitter included).
      const int face = std::uniform_int_distribution<int>(0, 3)(rng);
      const int axis = face % 2;
      const double side = face < 2 ? 1.0 : -1.0;
      const double depth = uniform(rng, 0.3, 0.7);
      const double along = uniform(rng, 0.5, 1.5);
      Vector2d local;
      local[axis] = side * (0.5 * size[axis] + 0.5 * depth);
      local[1 - axis] = uniform(rng, -0.4, 0.4) * size[1 - axis];
      Vector2d extent;
      extent[axis] = depth;
      extent[1 - axis] = along;
      const Eigen::Rotation2Dd rotation(yaw);
      const double rubble_yaw = yaw + uniform(rng, -0.1, 0.1);
      const double rubble_height = uniform(rng, 0.3, 1.0);
      world.add(Box::upright(center + rotation * local, extent, rubble_yaw, -kSeamM, rubble_height,
                             0.4F));
    }
  }

  RoadMap& roads = world.roadMap();
  const int nx = p.mine_pillars_x + 1;
  const int ny = p.mine_pillars_y + 1;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) roads.addNode({0.5 * d + i * pitch, 0.5 * d + j * pitch});
  }
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      if (i + 1 < nx) roads.addEdge(j * nx + i, j * nx + i + 1);
      if (j + 1 < ny) roads.addEdge(j * nx + i, (j + 1) * nx + i);
    }
  }
  return world;
}

// --- building -----------------------------------------------------------------------------------

constexpr double kInteriorWallM = 0.15;

/// An axis-aligned wall from `from` to `to` with door openings (centre along the wall, width).
void addWall(World& world, const Vector2d& from, const Vector2d& to,
             std::vector<std::pair<double, double>> doors, double height) {
  const Vector2d direction = (to - from).normalized();
  const double length = (to - from).norm();
  const double yaw = std::atan2(direction.y(), direction.x());
  std::sort(doors.begin(), doors.end());
  double start = 0.0;
  auto piece = [&](double a, double b) {
    if (b - a < 1e-6) return;
    world.add(Box::upright(from + 0.5 * (a + b) * direction, {b - a, kInteriorWallM}, yaw, -kSeamM,
                           height + kSeamM, 0.55F));
  };
  for (const auto& [center, width] : doors) {
    piece(start, center - 0.5 * width);
    start = center + 0.5 * width;
  }
  piece(start, length);
}

World buildBuilding(const WorldParams& p, Rng& rng) {
  const double room = p.building_room_size_m;
  const double corridor = p.building_corridor_width_m;
  const double door = p.building_door_width_m;
  const double h = p.building_height_m;
  const double pitch = 2 * room + corridor;
  const double size_x = p.building_blocks_x * pitch + corridor;
  const double size_y = p.building_blocks_y * pitch + corridor;
  World world("building", 0.0, h);
  addOuterWalls(world, size_x, size_y, h);
  RoadMap& roads = world.roadMap();

  // Corridor centrelines: x = lines_x[i] (vertical), y = lines_y[j] (horizontal). Nodes on each
  // line are collected with their position along it and chained once all are known.
  std::vector<double> lines_x;
  std::vector<double> lines_y;
  for (int i = 0; i <= p.building_blocks_x; ++i) lines_x.push_back(0.5 * corridor + i * pitch);
  for (int j = 0; j <= p.building_blocks_y; ++j) lines_y.push_back(0.5 * corridor + j * pitch);
  std::map<int, std::vector<std::pair<double, int>>> on_vertical;
  std::map<int, std::vector<std::pair<double, int>>> on_horizontal;
  for (size_t j = 0; j < lines_y.size(); ++j) {
    for (size_t i = 0; i < lines_x.size(); ++i) {
      const int node = roads.addNode({lines_x[i], lines_y[j]});
      on_vertical[i].push_back({lines_y[j], node});
      on_horizontal[j].push_back({lines_x[i], node});
    }
  }

  const double margin = 0.5 + 0.5 * door;  // door edge to room corner
  for (int bi = 0; bi < p.building_blocks_x; ++bi) {
    for (int bj = 0; bj < p.building_blocks_y; ++bj) {
      const Vector2d origin(corridor + bi * pitch, corridor + bj * pitch);
      // Doors on the block's outline: per side, (centre along the side, width).
      std::vector<std::pair<double, double>> bottom, top, left, right;
      for (int a = 0; a < 2; ++a) {
        for (int b = 0; b < 2; ++b) {
          const Vector2d room_center = origin + Vector2d((a + 0.5) * room, (b + 0.5) * room);
          const int center_node = roads.addNode(room_center);
          const double offset = uniform(rng, margin, room - margin);
          const bool horizontal_side = std::bernoulli_distribution(0.5)(rng);
          Vector2d corridor_point, inside_point;
          if (horizontal_side) {
            const double x = origin.x() + a * room + offset;
            (b == 0 ? bottom : top).push_back({a * room + offset, door});
            const int line = bj + b;
            corridor_point = {x, lines_y[line]};
            inside_point = {x, room_center.y() + (b == 0 ? -0.5 : 0.5) * (room - 2.0)};
            const int node = roads.addNode(corridor_point);
            on_horizontal[line].push_back({x, node});
            const int inside = roads.addNode(inside_point);
            roads.addEdge(node, inside);
            roads.addEdge(inside, center_node);
          } else {
            const double y = origin.y() + b * room + offset;
            (a == 0 ? left : right).push_back({b * room + offset, door});
            const int line = bi + a;
            corridor_point = {lines_x[line], y};
            inside_point = {room_center.x() + (a == 0 ? -0.5 : 0.5) * (room - 2.0), y};
            const int node = roads.addNode(corridor_point);
            on_vertical[line].push_back({y, node});
            const int inside = roads.addNode(inside_point);
            roads.addEdge(node, inside);
            roads.addEdge(inside, center_node);
          }
        }
      }
      const Vector2d x_extent(2 * room, 0.0);
      const Vector2d y_extent(0.0, 2 * room);
      addWall(world, origin, origin + x_extent, bottom, h);
      addWall(world, origin + y_extent, origin + x_extent + y_extent, top, h);
      addWall(world, origin, origin + y_extent, left, h);
      addWall(world, origin + x_extent, origin + x_extent + y_extent, right, h);
      addWall(world, origin + Vector2d(room, 0.0), origin + Vector2d(room, 2 * room), {}, h);
      addWall(world, origin + Vector2d(0.0, room), origin + Vector2d(2 * room, room), {}, h);
    }
  }
  for (auto* lines : {&on_vertical, &on_horizontal}) {
    for (auto& [line, nodes] : *lines) {
      std::sort(nodes.begin(), nodes.end());
      for (size_t k = 1; k < nodes.size(); ++k) roads.addEdge(nodes[k - 1].second, nodes[k].second);
    }
  }
  return world;
}

// --- cave ---------------------------------------------------------------------------------------

/// Smooth noise in [-1, 1]: bilinear interpolation of random values on a square lattice.
class LatticeNoise {
 public:
  LatticeNoise(double x_size, double y_size, double spacing, Rng& rng)
      : spacing_(spacing),
        nx_(static_cast<int>(x_size / spacing) + 2),
        ny_(static_cast<int>(y_size / spacing) + 2) {
    values_.resize(static_cast<size_t>(nx_) * ny_);
    for (auto& v : values_) v = uniform(rng, -1.0, 1.0);
  }
  double operator()(double x, double y) const {
    const double gx = std::clamp(x / spacing_, 0.0, nx_ - 1.001);
    const double gy = std::clamp(y / spacing_, 0.0, ny_ - 1.001);
    const int ix = static_cast<int>(gx);
    const int iy = static_cast<int>(gy);
    const double fx = gx - ix;
    const double fy = gy - iy;
    auto at = [&](int i, int j) { return values_[static_cast<size_t>(j) * nx_ + i]; };
    return (1 - fy) * ((1 - fx) * at(ix, iy) + fx * at(ix + 1, iy)) +
           fy * ((1 - fx) * at(ix, iy + 1) + fx * at(ix + 1, iy + 1));
  }

 private:
  double spacing_;
  int nx_;
  int ny_;
  std::vector<double> values_;
};

int findRoot(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

World buildCave(const WorldParams& p, Rng& rng) {
  const double spacing = p.cave_spacing_m;
  const double margin = 0.5 * spacing;
  const double size_x = (p.cave_nodes_x - 1) * spacing + 2 * margin;
  const double size_y = (p.cave_nodes_y - 1) * spacing + 2 * margin;
  const double h = p.cave_height_m;
  World world("cave", 0.0, h);
  RoadMap& roads = world.roadMap();

  for (int j = 0; j < p.cave_nodes_y; ++j) {
    for (int i = 0; i < p.cave_nodes_x; ++i) {
      const double jitter = 0.2 * spacing;
      roads.addNode({margin + i * spacing + uniform(rng, -jitter, jitter),
                     margin + j * spacing + uniform(rng, -jitter, jitter)});
    }
  }
  const int junctions = roads.nodeCount();
  // Tunnels: a random spanning tree of the grid graph (so all junctions connect) plus each
  // remaining grid edge with cave_loop_probability.
  std::vector<std::pair<int, int>> grid_edges;
  for (int j = 0; j < p.cave_nodes_y; ++j) {
    for (int i = 0; i < p.cave_nodes_x; ++i) {
      const int n = j * p.cave_nodes_x + i;
      if (i + 1 < p.cave_nodes_x) grid_edges.push_back({n, n + 1});
      if (j + 1 < p.cave_nodes_y) grid_edges.push_back({n, n + p.cave_nodes_x});
    }
  }
  std::shuffle(grid_edges.begin(), grid_edges.end(), rng);
  std::vector<int> parent(junctions);
  std::iota(parent.begin(), parent.end(), 0);
  std::bernoulli_distribution extra(p.cave_loop_probability);
  std::vector<std::pair<int, int>> tunnels;
  for (const auto& [a, b] : grid_edges) {
    const int ra = findRoot(parent, a);
    const int rb = findRoot(parent, b);
    if (ra != rb) {
      parent[ra] = rb;
      tunnels.push_back({a, b});
    } else if (extra(rng)) {
      tunnels.push_back({a, b});
    }
  }

  // Each tunnel: a wiggling centreline (road map nodes) with a half-width varying along it.
  struct Piece {
    Vector2d a, b;
    double radius_a, radius_b;
  };
  std::vector<Piece> pieces;
  const double r_min = p.cave_radius_min_m;
  const double r_max = p.cave_radius_max_m;
  for (const auto& [a, b] : tunnels) {
    const Vector2d from = roads.node(a);
    const Vector2d to = roads.node(b);
    const double length = (to - from).norm();
    const Vector2d normal = Vector2d(-(to - from).y(), (to - from).x()) / length;
    const int steps = std::max(2, static_cast<int>(std::ceil(length / 2.5)));
    const double bend = uniform(rng, -0.12, 0.12) * length;
    const double wiggle = uniform(rng, -0.04, 0.04) * length;
    const double wavelength = uniform(rng, 8.0, 15.0);
    const double phase = uniform(rng, 0.0, 2 * kPi);
    auto radius = [&](double s) {
      return r_min +
             (r_max - r_min) * (0.5 + 0.5 * std::sin(2 * kPi * s * length / wavelength + phase));
    };
    int previous = a;
    Vector2d previous_point = from;
    double previous_radius = radius(0.0);
    for (int k = 1; k <= steps; ++k) {
      const double s = static_cast<double>(k) / steps;
      const Vector2d point =
          k == steps ? to
                     : from + s * (to - from) +
                           normal * (bend * std::sin(kPi * s) + wiggle * std::sin(3 * kPi * s));
      const int node = k == steps ? b : roads.addNode(point);
      roads.addEdge(previous, node);
      pieces.push_back({previous_point, point, previous_radius, radius(s)});
      previous = node;
      previous_point = point;
      previous_radius = radius(s);
    }
  }

  // Free space: f > 0 inside tunnels and junction chambers, roughened by smooth noise; walls are
  // the f = 0 contour (marching squares).
  const double cell = 0.25;
  const int gx = static_cast<int>(std::ceil(size_x / cell)) + 1;
  const int gy = static_cast<int>(std::ceil(size_y / cell)) + 1;
  std::vector<double> field(static_cast<size_t>(gx) * gy, -10.0);
  auto at = [&](int i, int j) -> double& { return field[static_cast<size_t>(j) * gx + i]; };
  const double reach = r_max + p.cave_roughness_m + 2 * cell;
  auto carve = [&](const Piece& piece) {
    const Vector2d lo = piece.a.cwiseMin(piece.b).array() - reach;
    const Vector2d hi = piece.a.cwiseMax(piece.b).array() + reach;
    const Vector2d edge = piece.b - piece.a;
    const double length2 = std::max(edge.squaredNorm(), 1e-12);
    for (int j = std::max(0, static_cast<int>(lo.y() / cell));
         j <= std::min(gy - 1, static_cast<int>(hi.y() / cell) + 1); ++j) {
      for (int i = std::max(0, static_cast<int>(lo.x() / cell));
           i <= std::min(gx - 1, static_cast<int>(hi.x() / cell) + 1); ++i) {
        const Vector2d q(i * cell, j * cell);
        const double s = std::clamp((q - piece.a).dot(edge) / length2, 0.0, 1.0);
        const double r = piece.radius_a + s * (piece.radius_b - piece.radius_a);
        at(i, j) = std::max(at(i, j), r - (q - (piece.a + s * edge)).norm());
      }
    }
  };
  for (const auto& piece : pieces) carve(piece);
  for (int n = 0; n < junctions; ++n) {
    carve({roads.node(n), roads.node(n), r_max + 0.5, r_max + 0.5});
  }
  const LatticeNoise noise(size_x, size_y, 1.5, rng);
  for (int j = 0; j < gy; ++j) {
    for (int i = 0; i < gx; ++i) at(i, j) += p.cave_roughness_m * noise(i * cell, j * cell);
  }
  // The grid's border is rock, so every contour is closed.
  for (int i = 0; i < gx; ++i) at(i, 0) = at(i, gy - 1) = -1.0;
  for (int j = 0; j < gy; ++j) at(0, j) = at(gx - 1, j) = -1.0;

  auto crossing = [&](int i0, int j0, int i1, int j1) {
    const double v0 = at(i0, j0);
    const double v1 = at(i1, j1);
    const double s = v0 / (v0 - v1);
    return Vector2d((i0 + s * (i1 - i0)) * cell, (j0 + s * (j1 - j0)) * cell);
  };
  for (int j = 0; j + 1 < gy; ++j) {
    for (int i = 0; i + 1 < gx; ++i) {
      // Corners counter-clockwise from (i, j); edges 0..3 follow them.
      const int ci[4] = {i, i + 1, i + 1, i};
      const int cj[4] = {j, j, j + 1, j + 1};
      int mask = 0;
      for (int k = 0; k < 4; ++k) mask |= (at(ci[k], cj[k]) > 0.0 ? 1 : 0) << k;
      if (mask == 0 || mask == 15) continue;
      std::vector<Vector2d> points;  // crossings on edges, in edge order
      for (int k = 0; k < 4; ++k) {
        const int k1 = (k + 1) % 4;
        if (((mask >> k) & 1) != ((mask >> k1) & 1)) {
          points.push_back(crossing(ci[k], cj[k], ci[k1], cj[k1]));
        }
      }
      auto wall = [&](const Vector2d& a, const Vector2d& b) {
        world.add(
            Wall{a, b, -kSeamM, h + kSeamM, static_cast<float>(0.45 + 0.1 * noise(a.x(), a.y()))});
      };
      if (points.size() == 2) {
        wall(points[0], points[1]);
      } else {
        // Saddle: the centre decides whether the two free corners connect.
        const double center = 0.25 * (at(i, j) + at(i + 1, j) + at(i + 1, j + 1) + at(i, j + 1));
        const bool corner0_free = mask & 1;
        if ((center > 0.0) == corner0_free) {
          wall(points[0], points[1]);
          wall(points[2], points[3]);
        } else {
          wall(points[1], points[2]);
          wall(points[3], points[0]);
        }
      }
    }
  }
  return world;
}

// --- cluttered room -----------------------------------------------------------------------------

double distanceToSegment(const Vector2d& q, const Vector2d& a, const Vector2d& b) {
  const Vector2d edge = b - a;
  const double s = std::clamp((q - a).dot(edge) / std::max(edge.squaredNorm(), 1e-12), 0.0, 1.0);
  return (q - (a + s * edge)).norm();
}

World buildCluttered(const WorldParams& p, Rng& rng) {
  const double sx = p.cluttered_size_x_m;
  const double sy = p.cluttered_size_y_m;
  const double h = p.cluttered_height_m;
  World world("cluttered", 0.0, h);
  addOuterWalls(world, sx, sy, h);

  // Lanes: a loop inset from the walls and a cross lane through the middle.
  const double inset = std::min(4.0, 0.25 * std::min(sx, sy));
  RoadMap& roads = world.roadMap();
  const int c0 = roads.addNode({inset, inset});
  const int m0 = roads.addNode({0.5 * sx, inset});
  const int c1 = roads.addNode({sx - inset, inset});
  const int c2 = roads.addNode({sx - inset, sy - inset});
  const int m1 = roads.addNode({0.5 * sx, sy - inset});
  const int c3 = roads.addNode({inset, sy - inset});
  for (const auto& [a, b] :
       {std::pair{c0, m0}, {m0, c1}, {c1, c2}, {c2, m1}, {m1, c3}, {c3, c0}, {m0, m1}}) {
    roads.addEdge(a, b);
  }
  auto clear_of_lanes = [&](const Vector2d& center, double radius) {
    constexpr double kClearanceM = 1.2;
    for (int n = 0; n < roads.nodeCount(); ++n) {
      for (int m : roads.neighbours(n)) {
        if (distanceToSegment(center, roads.node(n), roads.node(m)) < radius + kClearanceM) {
          return false;
        }
      }
    }
    return true;
  };

  const int attempts = 50 * (p.cluttered_boxes + p.cluttered_columns);
  int boxes = 0;
  int columns = 0;
  for (int attempt = 0;
       attempt < attempts && (boxes < p.cluttered_boxes || columns < p.cluttered_columns);
       ++attempt) {
    const bool column =
        columns < p.cluttered_columns && (boxes >= p.cluttered_boxes || attempt % 4 == 0);
    if (column) {
      const double radius = uniform(rng, 0.15, 0.5);
      const Vector2d c =
          uniform2(rng, Vector2d::Constant(radius), Vector2d(sx, sy).array() - radius);
      if (!clear_of_lanes(c, radius)) continue;
      world.add(Cylinder{c, radius, -kSeamM, h + kSeamM, 0.5F});
      ++columns;
      continue;
    }
    const Vector2d size = uniform2(rng, Vector2d::Constant(0.3), Vector2d::Constant(2.0));
    const double half_diagonal = 0.5 * size.norm();
    const Vector2d c =
        uniform2(rng, Vector2d::Constant(half_diagonal), Vector2d(sx, sy).array() - half_diagonal);
    if (!clear_of_lanes(c, half_diagonal)) continue;
    // On the floor, a tall stack, a shelf in mid-air, or hanging from the ceiling.
    double z0 = 0.0;
    double z1 = 0.0;
    switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
      case 0:
        z0 = -kSeamM;
        z1 = uniform(rng, 0.3, 1.5);
        break;
      case 1:
        z0 = -kSeamM;
        z1 = uniform(rng, 2.0, std::min(4.0, h - 0.5));
        break;
      case 2:
        z0 = uniform(rng, 1.0, h - 1.5);
        z1 = z0 + uniform(rng, 0.1, 1.0);
        break;
      default:
        z1 = h + kSeamM;
        z0 = h - uniform(rng, 0.5, 2.0);
        break;
    }
    const double yaw = uniform(rng, 0.0, kPi);
    const auto reflectivity = static_cast<float>(uniform(rng, 0.2, 0.9));
    world.add(Box::upright(c, size, yaw, z0, z1, reflectivity));
    ++boxes;
  }
  return world;
}

}  // namespace

World buildWorld(const WorldParams& params, std::uint64_t seed) {
  validated(params);
  Rng rng(seed);
  World world = params.world == "building"    ? buildBuilding(params, rng)
                : params.world == "cave"      ? buildCave(params, rng)
                : params.world == "cluttered" ? buildCluttered(params, rng)
                                              : buildMine(params, rng);
  world.buildIndex(params.index_cell_m);
  return world;
}

}  // namespace ccir_mapping::core::simulation
