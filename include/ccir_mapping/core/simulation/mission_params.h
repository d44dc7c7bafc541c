// Everything that defines a simulated team mission; the seed makes it reproducible.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/simulation/lidar_params.h"
#include "ccir_mapping/core/simulation/odometry_params.h"
#include "ccir_mapping/core/simulation/world_params.h"

namespace ccir_mapping::core::simulation {

struct MissionParams {
  int seed = 7;
  int robots = 3;
  /// The last `aerial_robots` robots fly (varying height); the others drive.
  int aerial_robots = 0;
  double duration_s = 120.0;
  /// Simulated time of the mission start (bag stamps start here).
  double start_time_s = 100.0;
  /// Robot i starts i * start_interval_s after the mission start.
  double start_interval_s = 5.0;
  /// Chance that a robot at a junction takes a lane a teammate drove before (0: explore, 1:
  /// follow), which sets how much the trajectories overlap.
  double overlap = 0.5;
  double ground_speed_mps = 1.0;
  double aerial_speed_mps = 1.0;
  /// Radius of the arcs that round corners; sharper turns than 150 deg are made on the spot.
  double turn_radius_m = 1.0;
  double turn_rate_rad_per_s = 0.8;
  /// Lidar above base_link (base_link is on the floor for ground robots).
  double sensor_height_m = 0.5;
  double aerial_min_height_m = 1.0;
  double aerial_max_height_m = 2.0;
  double aerial_height_period_s = 20.0;

  WorldParams world;
  LidarParams lidar;
  OdometryParams odometry;

  template <class Self, class Visitor>
  static void fields(Self& p, Visitor& v) {
    v.integer("seed", p.seed, "", 0, 2147483647, "seed of every random choice");
    v.integer("robots", p.robots, "", 1, 200, "robots in the team");
    v.integer("aerial_robots", p.aerial_robots, "", 0, 50,
              "how many of them fly (the last ones); the others drive");
    v.number("duration_s", p.duration_s, "s", 0.5, 7200.0, "mission length");
    v.number("start_time_s", p.start_time_s, "s", 1.0, 1e9, "simulated time of the mission start");
    v.number("start_interval_s", p.start_interval_s, "s", 0.0, 3600.0,
             "robot i starts i times this after the mission start");
    v.number("overlap", p.overlap, "", 0.0, 1.0,
             "chance to take a lane a teammate drove before (0 explore .. 1 follow)");
    v.number("ground_speed_mps", p.ground_speed_mps, "m/s", 0.05, 5.0, "ground robot speed");
    v.number("aerial_speed_mps", p.aerial_speed_mps, "m/s", 0.05, 10.0, "aerial robot speed");
    v.number("turn_radius_m", p.turn_radius_m, "m", 0.0, 5.0, "radius of rounded corners");
    v.number("turn_rate_rad_per_s", p.turn_rate_rad_per_s, "rad/s", 0.05, 5.0,
             "turn rate for turns on the spot");
    v.number("sensor_height_m", p.sensor_height_m, "m", 0.05, 3.0, "lidar above base_link");
    v.number("aerial_min_height_m", p.aerial_min_height_m, "m", 0.3, 50.0,
             "lowest flight height of base_link");
    v.number("aerial_max_height_m", p.aerial_max_height_m, "m", 0.3, 50.0,
             "highest flight height of base_link");
    v.number("aerial_height_period_s", p.aerial_height_period_s, "s", 1.0, 3600.0,
             "period of the flight height oscillation");
    WorldParams::fields(p.world, v);
    LidarParams::fields(p.lidar, v);
    OdometryParams::fields(p.odometry, v);
  }

  /// Ranges of every field and the constraints between them (aerial robots fit under the ceiling
  /// and so on); each error names its parameter.
  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::simulation
