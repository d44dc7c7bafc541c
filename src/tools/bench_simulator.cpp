// bench_simulator: how fast the simulator produces VLP-16 scans for one robot on one thread,
// per world, against the same rays cast without the spatial index (measured in the same run).
// Prints JSON. Target: >= 100 scans/s (10 x real time) in the mine.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/simulation/mission.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace sim = ccir_mapping::core::simulation;
namespace tools = ccir_mapping::tools;
using ccir_mapping::core::Pose3;

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct WorldResult {
  std::string world;
  size_t solids = 0;
  int scans = 0;
  double scans_per_s = 0.0;
  double points_per_scan = 0.0;
  double rays_per_s = 0.0;
  double brute_force_rays_per_s = 0.0;
};

WorldResult run(const std::string& world, int scans, int brute_force_scans, int seed) {
  sim::MissionParams params;
  params.world.world = world;
  params.robots = 1;
  params.seed = seed;
  const sim::Mission mission(params);
  const auto& robot = mission.robots().front();
  const sim::LidarModel& lidar = mission.lidar();
  const Pose3 mount = mission.sensorMount();
  std::mt19937_64 rng(1);

  WorldResult result;
  result.world = world;
  result.solids = mission.world().boxes().size() + mission.world().cylinders().size() +
                  mission.world().walls().size();
  result.scans = scans;
  // Scans along the robot's path, as simulate_team makes them (without writing bags).
  size_t points = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < scans; ++k) {
    const double offset = k * lidar.sweepSeconds();
    const auto scan = lidar.scan(
        mission.world(), 0, [&](double t) { return robot.trajectory.poseAt(offset + t) * mount; },
        rng);
    points += scan.points.size();
  }
  const double seconds = secondsSince(start);
  const double rays =
      static_cast<double>(scans) * sim::LidarModel::kRings * params.lidar.lidar_columns;
  result.scans_per_s = scans / seconds;
  result.points_per_scan = static_cast<double>(points) / scans;
  result.rays_per_s = rays / seconds;

  // Baseline: the same beams against every solid.
  size_t hits = 0;
  const auto brute_start = std::chrono::steady_clock::now();
  for (int k = 0; k < brute_force_scans; ++k) {
    const Pose3 pose = robot.trajectory.poseAt(k * lidar.sweepSeconds()) * mount;
    for (int c = 0; c < params.lidar.lidar_columns; ++c) {
      const double azimuth = lidar.azimuthRad(c);
      for (int r = 0; r < sim::LidarModel::kRings; ++r) {
        const double elevation = sim::LidarModel::elevationRad(r);
        const Eigen::Vector3d direction(std::cos(elevation) * std::cos(azimuth),
                                        std::cos(elevation) * std::sin(azimuth),
                                        std::sin(elevation));
        hits += mission.world()
                    .castRayBruteForce({pose.translation(), pose.linear() * direction},
                                       params.lidar.lidar_max_range_m)
                    .has_value();
      }
    }
  }
  const double brute_rays =
      static_cast<double>(brute_force_scans) * sim::LidarModel::kRings * params.lidar.lidar_columns;
  result.brute_force_rays_per_s = brute_rays / secondsSince(brute_start);
  if (hits == 0) std::cerr << "bench_simulator: no beam hit anything in the " << world << '\n';
  return result;
}

struct Options {
  std::vector<std::string> worlds;
  int scans = 300;
  int brute_force_scans = 3;
  int seed = 7;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  std::string worlds = "all";
  po::options_description options(
      "Usage: bench_simulator [--world all|mine|building|cave|cluttered] [--scans N]\n"
      "Prints JSON: VLP-16 scans per second for one robot on one thread, per world.\n\nOptions");
  options.add_options()("help,h", "print this help and exit")(
      "world", po::value<std::string>(&worlds)->default_value(worlds), "world(s) to measure")(
      "scans", po::value<int>(&o->scans)->default_value(o->scans), "scans per world")(
      "brute-force-scans",
      po::value<int>(&o->brute_force_scans)->default_value(o->brute_force_scans),
      "scans for the baseline without the spatial index")(
      "seed", po::value<int>(&o->seed)->default_value(o->seed), "mission seed");
  if (const auto exit_code = tools::parseCommandLine("bench_simulator", options, argc, argv)) {
    return exit_code;
  }
  o->worlds = worlds == "all" ? sim::WorldParams::worldChoices() : std::vector{worlds};
  if (o->scans < 1 || o->brute_force_scans < 1) {
    return tools::usageError("bench_simulator", "--scans and --brute-force-scans must be >= 1");
  }
  return std::nullopt;
}

constexpr double kTargetScansPerS = 100.0;

void report(const std::vector<WorldResult>& results) {
  std::printf(
      "{\n  \"benchmark\": \"simulator\",\n  \"threads\": 1,\n"
      "  \"lidar\": {\"rings\": 16, \"columns\": 1800, \"rate_hz\": 10},\n"
      "  \"target_scans_per_s\": %.0f,\n  \"worlds\": {\n",
      kTargetScansPerS);
  bool mine_meets_target = true;
  for (size_t i = 0; i < results.size(); ++i) {
    const WorldResult& r = results[i];
    if (r.world == "mine") mine_meets_target = r.scans_per_s >= kTargetScansPerS;
    std::printf(
        "    \"%s\": {\"solids\": %zu, \"scans\": %d, \"scans_per_s\": %.1f, "
        "\"real_time_factor\": %.1f, \"points_per_scan\": %.0f, \"rays_per_s\": %.0f, "
        "\"brute_force_rays_per_s\": %.0f, \"index_speedup\": %.1f}%s\n",
        r.world.c_str(), r.solids, r.scans, r.scans_per_s, r.scans_per_s / 10.0, r.points_per_scan,
        r.rays_per_s, r.brute_force_rays_per_s, r.rays_per_s / r.brute_force_rays_per_s,
        i + 1 < results.size() ? "," : "");
  }
  std::printf("  },\n  \"mine_meets_target\": %s\n}\n", mine_meets_target ? "true" : "false");
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  std::vector<WorldResult> results;
  try {
    for (const std::string& world : options.worlds) {
      results.push_back(run(world, options.scans, options.brute_force_scans, options.seed));
    }
  } catch (const std::exception& e) {
    return tools::usageError("bench_simulator", e.what());  // an unknown world
  }
  report(results);
  return 0;
}
