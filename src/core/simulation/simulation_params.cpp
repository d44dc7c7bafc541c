// validate() of the simulation's Params structs: ranges come from fields(), the rest are the
// constraints between fields.
#include <cmath>
#include <sstream>

#include "ccir_mapping/core/common/field_check.h"
#include "ccir_mapping/core/simulation/lidar_params.h"
#include "ccir_mapping/core/simulation/mission_params.h"
#include "ccir_mapping/core/simulation/odometry_params.h"
#include "ccir_mapping/core/simulation/world_params.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Free width a robot needs on each side of its lane.
constexpr double kLaneClearanceM = 1.0;

template <class Params>
std::vector<std::string> checkFields(const Params& params) {
  FieldCheck check;
  Params::fields(params, check);
  return check.check().errors();
}

std::string str(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

const std::vector<std::string>& WorldParams::worldChoices() {
  static const std::vector<std::string> choices{"mine", "building", "cave", "cluttered"};
  return choices;
}

double WorldParams::height() const {
  if (world == "building") return building_height_m;
  if (world == "cave") return cave_height_m;
  if (world == "cluttered") return cluttered_height_m;
  return mine_height_m;
}

static double mineLaneClearance(const WorldParams& p) {
  // How far a pillar face can reach into the drift: half the size jitter, the corner swing of the
  // rotation, and a rubble box.
  const double half_size = 0.5 * (p.mine_pillar_size_m + p.mine_size_jitter_m);
  const double swing = half_size * std::sin(p.mine_rotation_jitter_deg * kPi / 180.0);
  const double rubble = p.mine_rubble_per_pillar > 0.0 ? WorldParams::kMineRubbleDepthMaxM : 0.0;
  return 0.5 * p.mine_drift_width_m - 0.5 * p.mine_size_jitter_m - swing - rubble;
}

std::vector<std::string> WorldParams::validate() const {
  std::vector<std::string> errors = checkFields(*this);
  for (auto& e : constraints()) errors.push_back(std::move(e));
  return errors;
}

std::vector<std::string> WorldParams::constraints() const {
  ParamCheck check;
  if (world == "mine") {
    const double clearance = mineLaneClearance(*this);
    check.require(clearance >= kLaneClearanceM,
                  "mine_drift_width_m = " + str(mine_drift_width_m) + " leaves only " +
                      str(clearance) +
                      " m beside the drift centre with this pillar jitter and rubble: allowed >= " +
                      str(kLaneClearanceM) + " m");
  }
  if (world == "building") {
    check.require(building_door_width_m <= building_room_size_m - 1.0,
                  "building_door_width_m = " + str(building_door_width_m) +
                      " does not fit a room of building_room_size_m = " +
                      str(building_room_size_m) + ": allowed <= room size - 1 m");
  }
  if (world == "cave") {
    check.require(cave_radius_min_m <= cave_radius_max_m,
                  "cave_radius_min_m = " + str(cave_radius_min_m) +
                      " is above cave_radius_max_m = " + str(cave_radius_max_m));
    check.require(cave_radius_max_m + cave_roughness_m <= cave_spacing_m / 3.0,
                  "cave_radius_max_m = " + str(cave_radius_max_m) +
                      " plus roughness is too wide for cave_spacing_m = " + str(cave_spacing_m) +
                      ": allowed <= spacing / 3");
    check.require(cave_radius_min_m - cave_roughness_m >= kLaneClearanceM,
                  "cave_roughness_m = " + str(cave_roughness_m) +
                      " can close tunnels of cave_radius_min_m = " + str(cave_radius_min_m) +
                      ": allowed radius - roughness >= " + str(kLaneClearanceM) + " m");
  }
  return check.errors();
}

std::vector<std::string> LidarParams::validate() const {
  std::vector<std::string> errors = checkFields(*this);
  for (auto& e : constraints()) errors.push_back(std::move(e));
  return errors;
}

std::vector<std::string> LidarParams::constraints() const {
  std::vector<std::string> errors;
  if (!(lidar_min_range_m < lidar_max_range_m)) {
    errors.push_back("lidar_min_range_m = " + str(lidar_min_range_m) +
                     " must be below lidar_max_range_m = " + str(lidar_max_range_m));
  }
  return errors;
}

std::vector<std::string> OdometryParams::validate() const { return checkFields(*this); }

std::vector<std::string> MissionParams::validate() const {
  // fields() visits the nested structs' ranges too.
  std::vector<std::string> errors = checkFields(*this);
  ParamCheck check;
  check.require(aerial_robots <= robots, "aerial_robots = " + std::to_string(aerial_robots) +
                                             " is more than robots = " + std::to_string(robots));
  if (aerial_robots > 0) {
    check.require(aerial_min_height_m <= aerial_max_height_m,
                  "aerial_min_height_m = " + str(aerial_min_height_m) +
                      " is above aerial_max_height_m = " + str(aerial_max_height_m));
    const double room = world.height() - sensor_height_m - 0.5;
    check.require(aerial_max_height_m <= room,
                  "aerial_max_height_m = " + str(aerial_max_height_m) + " does not fit under the " +
                      world.world + "'s ceiling at " + str(world.height()) +
                      " m: allowed <= " + str(room) + " m (ceiling - sensor_height_m - 0.5 m)");
  }
  check.require(sensor_height_m <= world.height() - 0.5,
                "sensor_height_m = " + str(sensor_height_m) + " does not fit under the " +
                    world.world + "'s ceiling at " + str(world.height()) + " m");
  errors.insert(errors.end(), check.errors().begin(), check.errors().end());
  for (const auto& nested : {world.constraints(), lidar.constraints()}) {
    errors.insert(errors.end(), nested.begin(), nested.end());
  }
  return errors;
}

}  // namespace ccir_mapping::core::simulation
