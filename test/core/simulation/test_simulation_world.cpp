// Simulated worlds: exact ray tests on each solid, the grid index against brute force, closed
// worlds, lanes with room to drive, the mine's jitter bounds and determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ccir_mapping/core/simulation/world_builder.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;

Ray ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  return {origin, direction.normalized()};
}

Eigen::Vector3d randomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = n(rng);
  return v.normalized();
}

WorldParams paramsFor(const std::string& kind) {
  WorldParams params;
  params.world = kind;
  return params;
}

/// Points on the lanes robots drive: every road-map node and the midpoint of every edge.
std::vector<Eigen::Vector2d> lanePoints(const World& world, double step_m) {
  std::vector<Eigen::Vector2d> points;
  const RoadMap& roads = world.roadMap();
  for (int n = 0; n < roads.nodeCount(); ++n) {
    for (int m : roads.neighbours(n)) {
      if (m < n) continue;
      const Eigen::Vector2d a = roads.node(n);
      const Eigen::Vector2d b = roads.node(m);
      const int steps = std::max(1, static_cast<int>((b - a).norm() / step_m));
      for (int k = 0; k <= steps; ++k) points.push_back(a + (b - a) * k / steps);
    }
  }
  return points;
}

TEST(Primitives, BoxFacesAndRotation) {
  const Box box = Box::upright({0, 0}, {2, 2}, 0.0, 0.0, 2.0, 0.5F);
  Hit hit;
  ASSERT_TRUE(box.intersect(ray({-5, 0, 1}, {1, 0, 0}), 100.0, &hit));
  EXPECT_NEAR(hit.range, 4.0, 1e-12);
  EXPECT_NEAR(hit.normal.x(), -1.0, 1e-12);
  ASSERT_TRUE(box.intersect(ray({0.5, 0, 5}, {0, 0, -1}), 100.0, &hit));  // top face
  EXPECT_NEAR(hit.range, 3.0, 1e-12);
  EXPECT_NEAR(hit.normal.z(), 1.0, 1e-12);
  EXPECT_FALSE(box.intersect(ray({-5, 0, 2.5}, {1, 0, 0}), 100.0, &hit));  // above it
  EXPECT_FALSE(box.intersect(ray({-5, 0, 1}, {1, 0, 0}), 3.9, &hit));      // beyond max range
  EXPECT_FALSE(box.intersect(ray({0, 0, 1}, {1, 0, 0}), 100.0, &hit));     // from inside

  // Rotated by 45 deg, the box shows a corner at x = -sqrt(2) to a ray along x.
  const Box diamond = Box::upright({0, 0}, {2, 2}, kPi / 4, 0.0, 2.0, 0.5F);
  ASSERT_TRUE(diamond.intersect(ray({-5, 0, 1}, {1, 0, 0}), 100.0, &hit));
  EXPECT_NEAR(hit.range, 5.0 - std::sqrt(2.0), 1e-9);
}

TEST(Primitives, CylinderSideAndCap) {
  const Cylinder column{{0, 0}, 1.0, 0.0, 3.0, 0.5F};
  Hit hit;
  ASSERT_TRUE(column.intersect(ray({-5, 0, 1}, {1, 0, 0}), 100.0, &hit));
  EXPECT_NEAR(hit.range, 4.0, 1e-12);
  EXPECT_NEAR(hit.normal.x(), -1.0, 1e-12);
  ASSERT_TRUE(column.intersect(ray({0.5, 0, 10}, {0, 0, -1}), 100.0, &hit));
  EXPECT_NEAR(hit.range, 7.0, 1e-12);
  EXPECT_NEAR(hit.normal.z(), 1.0, 1e-12);
  EXPECT_FALSE(column.intersect(ray({-5, 1.01, 1}, {1, 0, 0}), 100.0, &hit));
}

TEST(Primitives, WallSegmentAndHeight) {
  const Wall wall{{0, -1}, {0, 1}, 0.0, 2.0, 0.5F};
  Hit hit;
  ASSERT_TRUE(wall.intersect(ray({3, 0, 1}, {-1, 0, 0}), 100.0, &hit));
  EXPECT_NEAR(hit.range, 3.0, 1e-12);
  EXPECT_NEAR(hit.normal.x(), 1.0, 1e-12);  // faces the ray: walls are seen from both sides
  ASSERT_TRUE(wall.intersect(ray({-3, 0, 1}, {1, 0, 0}), 100.0, &hit));
  EXPECT_NEAR(hit.normal.x(), -1.0, 1e-12);
  EXPECT_FALSE(wall.intersect(ray({3, 1.5, 1}, {-1, 0, 0}), 100.0, &hit));  // past its end
  EXPECT_FALSE(wall.intersect(ray({3, 0, 2.5}, {-1, 0, 0}), 100.0, &hit));  // above it
}

TEST(World, FloorAndCeilingBoundEveryRay) {
  World world("empty", 0.0, 4.0);
  world.buildIndex(2.0);
  const auto down = world.castRay(ray({0, 0, 1}, {1, 0, -1}), 100.0);
  ASSERT_TRUE(down);
  EXPECT_NEAR(down->range, std::sqrt(2.0), 1e-12);
  const auto up = world.castRay(ray({0, 0, 1}, {0, 0, 1}), 100.0);
  ASSERT_TRUE(up);
  EXPECT_NEAR(up->range, 3.0, 1e-12);
  EXPECT_FALSE(world.castRay(ray({0, 0, 1}, {1, 0, 0}), 100.0));  // level: nothing to hit
}

class EveryWorld : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryWorld, IndexAgreesWithBruteForce) {
  const World world = buildWorld(paramsFor(GetParam()), 3);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> offset(-1.0, 1.0);
  std::uniform_real_distribution<double> height(0.2, world.ceilingZ() - 0.2);
  const auto points = lanePoints(world, 2.0);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d p = points[i % points.size()];
    // Also start some rays outside the world to exercise the grid entry.
    const Eigen::Vector3d origin =
        i % 50 == 0 ? Eigen::Vector3d(world.bounds().x_min - 5.0, p.y(), 1.0)
                    : Eigen::Vector3d(p.x() + offset(rng), p.y() + offset(rng), height(rng));
    const Ray r{origin, randomDirection(rng)};
    const auto indexed = world.castRay(r, 150.0);
    const auto brute = world.castRayBruteForce(r, 150.0);
    ASSERT_EQ(indexed.has_value(), brute.has_value()) << "ray " << i;
    if (indexed) {
      ++hits;
      ASSERT_NEAR(indexed->range, brute->range, 1e-9) << "ray " << i;
    }
  }
  EXPECT_GT(hits, 19000);
}

TEST_P(EveryWorld, IsClosed) {
  // No beam escapes: from every lane, every direction meets a surface within the world's extent.
  const World world = buildWorld(paramsFor(GetParam()), 4);
  const auto& b = world.bounds();
  const double diagonal = std::hypot(b.x_max - b.x_min, b.y_max - b.y_min);
  std::mt19937_64 rng(6);
  int rays = 0;
  for (const auto& p : lanePoints(world, 1.0)) {
    for (double z : {0.5, world.ceilingZ() - 0.5}) {
      for (int k = 0; k < 200; ++k, ++rays) {
        const auto hit = world.castRay({{p.x(), p.y(), z}, randomDirection(rng)}, 1e4);
        ASSERT_TRUE(hit) << GetParam() << ": a beam from (" << p.transpose() << ", " << z
                         << ") escaped";
        ASSERT_LT(hit->range, diagonal + world.ceilingZ());
      }
    }
  }
  EXPECT_GT(rays, 10000);
}

TEST_P(EveryWorld, LanesLeaveRoomToDrive) {
  // A robot on any lane, on the ground or flying, is at least 0.9 m from every solid, except in
  // a building's doorways (half the door's width).
  const WorldParams params = paramsFor(GetParam());
  const double clearance = GetParam() == "building" ? 0.5 * params.building_door_width_m : 0.9;
  const World world = buildWorld(params, 8);
  ASSERT_GT(world.roadMap().edgeCount(), 3);
  double nearest = 1e9;
  for (const auto& p : lanePoints(world, 0.5)) {
    for (double z : {0.5, 2.5}) {
      for (int k = 0; k < 72; ++k) {
        const double a = 2 * kPi * k / 72;
        const auto hit = world.castRay({{p.x(), p.y(), z}, {std::cos(a), std::sin(a), 0.0}}, 1e4);
        ASSERT_TRUE(hit);
        nearest = std::min(nearest, hit->range);
      }
    }
  }
  EXPECT_GE(nearest, clearance - 1e-6) << GetParam();
}

TEST_P(EveryWorld, SameSeedSameWorldOtherSeedOther) {
  const World a = buildWorld(paramsFor(GetParam()), 11);
  const World b = buildWorld(paramsFor(GetParam()), 11);
  const World c = buildWorld(paramsFor(GetParam()), 12);
  auto fingerprint = [](const World& w) {
    double sum = 0.0;
    for (const auto& box : w.boxes()) sum += box.center.sum() + box.half_size.sum() + box.axis.y();
    for (const auto& cylinder : w.cylinders()) sum += cylinder.center.sum() + cylinder.radius;
    for (const auto& wall : w.walls()) sum += wall.a.sum() + wall.b.sum();
    return sum;
  };
  EXPECT_EQ(fingerprint(a), fingerprint(b));
  EXPECT_EQ(a.roadMap().nodeCount(), b.roadMap().nodeCount());
  EXPECT_NE(fingerprint(a), fingerprint(c));
}

INSTANTIATE_TEST_SUITE_P(Simulation, EveryWorld,
                         ::testing::Values("mine", "building", "cave", "cluttered"));

TEST(Mine, PillarsAlikeButNotIdentical) {
  WorldParams params;
  params.mine_pillars_x = 12;
  params.mine_pillars_y = 12;
  const World world = buildWorld(params, 21);
  const int pillars = 144;
  std::vector<const Box*> pillar_boxes;
  int rubble = 0;
  for (const auto& box : world.boxes()) {
    if (box.half_size.minCoeff() > 4.0 && box.half_size.maxCoeff() < 6.0) {
      pillar_boxes.push_back(&box);
    } else if (box.z_max < 1.5) {
      ++rubble;
    }
  }
  ASSERT_EQ(static_cast<int>(pillar_boxes.size()), pillars);
  double size_spread = 0.0;
  for (const Box* p : pillar_boxes) {
    for (int axis = 0; axis < 2; ++axis) {
      EXPECT_NEAR(2 * p->half_size[axis], params.mine_pillar_size_m, params.mine_size_jitter_m);
      size_spread = std::max(size_spread, std::abs(2 * p->half_size[axis] - 10.0));
    }
    const double yaw_deg = std::atan2(p->axis.y(), p->axis.x()) * 180.0 / kPi;
    EXPECT_LE(std::abs(yaw_deg), params.mine_rotation_jitter_deg + 1e-9);
  }
  EXPECT_GT(size_spread, 0.2);  // jittered, not a perfect grid
  // On average at most one rubble box per pillar: Bernoulli(0.5) per pillar.
  EXPECT_NEAR(rubble, 0.5 * pillars, 4 * std::sqrt(0.25 * pillars));

  params.mine_rubble_per_pillar = 0.0;
  const World clean = buildWorld(params, 21);
  EXPECT_EQ(clean.boxes().size(), static_cast<size_t>(pillars + 4));  // pillars + outer walls
  EXPECT_NEAR(clean.ceilingZ(), 4.0, 1e-12);
  // Drift centrelines every pillar + drift width.
  EXPECT_EQ(clean.roadMap().nodeCount(), 13 * 13);
}

TEST(WorldParams, InvalidCombinationsNameTheirParameter) {
  WorldParams narrow;
  narrow.mine_drift_width_m = 3.0;
  narrow.mine_rubble_per_pillar = 1.0;
  ASSERT_FALSE(narrow.validate().empty());
  EXPECT_EQ(narrow.validate().front().rfind("mine_drift_width_m", 0), 0U);
  EXPECT_THROW(buildWorld(narrow, 1), std::invalid_argument);

  WorldParams cave = paramsFor("cave");
  cave.cave_radius_min_m = 4.0;
  ASSERT_FALSE(cave.validate().empty());
  EXPECT_EQ(cave.validate().front().rfind("cave_radius_min_m", 0), 0U);

  WorldParams unknown = paramsFor("moon");
  ASSERT_EQ(unknown.validate().size(), 1U);
  EXPECT_NE(unknown.validate().front().find("mine | building | cave | cluttered"),
            std::string::npos);
  for (const auto& kind : WorldParams::worldChoices()) {
    EXPECT_TRUE(paramsFor(kind).validate().empty()) << kind;
  }
}

}  // namespace
}  // namespace ccir_mapping::core::simulation
