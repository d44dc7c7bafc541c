#include "ccir_mapping/core/simulation/mission.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "ccir_mapping/core/simulation/odometry_simulator.h"
#include "ccir_mapping/core/simulation/world_builder.h"

namespace ccir_mapping::core::simulation {
namespace {

constexpr double kPi = 3.14159265358979323846;

const MissionParams& validated(const MissionParams& params) {
  const auto errors = params.validate();
  if (errors.empty()) return params;
  std::string message = errors.front();
  for (size_t i = 1; i < errors.size(); ++i) message += "; " + errors[i];
  throw std::invalid_argument(message);
}

/// Independent random streams per purpose and robot (splitmix64 of the mission seed).
std::uint64_t streamSeed(int seed, int robot, int purpose) {
  std::uint64_t z = static_cast<std::uint64_t>(seed) * 0x9E3779B97F4A7C15ULL +
                    static_cast<std::uint64_t>(robot + 1) * 0xBF58476D1CE4E5B9ULL +
                    static_cast<std::uint64_t>(purpose + 1) * 0x94D049BB133111EBULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

enum Purpose { kWorldStream, kRouteStream, kHeightStream, kOdometryStream, kLidarStream };

std::pair<int, int> edgeKey(int a, int b) { return {std::min(a, b), std::max(a, b)}; }

}  // namespace

Mission::Mission(const MissionParams& params)
    : params_(validated(params)),
      world_(buildWorld(params.world, streamSeed(params.seed, -1, kWorldStream))),
      lidar_(params.lidar) {
  planRobots();
}

std::string Mission::robotName(int index) {
  std::string letters;
  do {
    letters.insert(letters.begin(), static_cast<char>('a' + index % 26));
    index /= 26;
  } while (index > 0);
  return "robot_" + letters;
}

Stamp Mission::startStamp() const { return fromSeconds(params_.start_time_s); }
Stamp Mission::endStamp() const { return fromSeconds(params_.start_time_s + params_.duration_s); }

Pose3 Mission::sensorMount() const {
  Pose3 mount = Pose3::Identity();
  mount.translation().z() = params_.sensor_height_m;
  return mount;
}

void Mission::planRobots() {
  const RoadMap& roads = world_.roadMap();
  std::mt19937_64 rng(streamSeed(params_.seed, -1, kRouteStream));
  // Start on lanes, not in dead ends; distinct nodes while there are enough.
  std::vector<int> starts;
  for (int n = 0; n < roads.nodeCount(); ++n) {
    if (roads.neighbours(n).size() >= 2) starts.push_back(n);
  }
  if (starts.empty()) throw std::logic_error("Mission: the road map has no lanes");
  std::shuffle(starts.begin(), starts.end(), rng);

  std::map<std::pair<int, int>, int> team_visits;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < params_.robots; ++i) {
    const bool aerial = i >= params_.robots - params_.aerial_robots;
    const double speed = aerial ? params_.aerial_speed_mps : params_.ground_speed_mps;
    const double start_offset = std::min(i * params_.start_interval_s, params_.duration_s);
    // Enough road for the whole mission (spins and arcs take a little extra time).
    const double needed_m = 1.2 * speed * (params_.duration_s - start_offset) + 20.0;

    std::vector<int> route{starts[static_cast<size_t>(i) % starts.size()]};
    std::map<std::pair<int, int>, int> own_visits;
    double length = 0.0;
    int previous = -1;
    while (length < needed_m) {
      const int current = route.back();
      std::vector<int> candidates = roads.neighbours(current);
      if (candidates.size() > 1) {
        candidates.erase(std::remove(candidates.begin(), candidates.end(), previous),
                         candidates.end());
      }
      auto count = [](const auto& visits, int a, int b) {
        const auto it = visits.find(edgeKey(a, b));
        return it == visits.end() ? 0 : it->second;
      };
      std::vector<int> choice;
      if (unit(rng) < params_.overlap) {  // follow a teammate
        for (int c : candidates) {
          if (count(team_visits, current, c) > 0) choice.push_back(c);
        }
      }
      if (choice.empty()) {  // explore: the lanes least driven by anyone
        int best = -1;
        for (int c : candidates) {
          const int visits = count(own_visits, current, c) + count(team_visits, current, c);
          if (best < 0 || visits < best) {
            best = visits;
            choice.clear();
          }
          if (visits == best) choice.push_back(c);
        }
      }
      const int next = choice[std::uniform_int_distribution<size_t>(0, choice.size() - 1)(rng)];
      ++own_visits[edgeKey(current, next)];
      length += (roads.node(next) - roads.node(current)).norm();
      previous = current;
      route.push_back(next);
    }
    for (const auto& [edge, visits] : own_visits) team_visits[edge] += visits;

    std::vector<Eigen::Vector2d> waypoints;
    for (int n : route) waypoints.push_back(roads.node(n));
    Trajectory::HeightAt height;
    if (aerial) {
      std::mt19937_64 height_rng(streamSeed(params_.seed, i, kHeightStream));
      const double phase = std::uniform_real_distribution<double>(0.0, 2 * kPi)(height_rng);
      const double mid = 0.5 * (params_.aerial_min_height_m + params_.aerial_max_height_m);
      const double amplitude = 0.5 * (params_.aerial_max_height_m - params_.aerial_min_height_m);
      const double period = params_.aerial_height_period_s;
      height = [=](double t) { return mid + amplitude * std::sin(2 * kPi * t / period + phase); };
    }
    Trajectory trajectory(waypoints, {speed, params_.turn_radius_m, params_.turn_rate_rad_per_s},
                          height);
    const Pose3 start = trajectory.poseAt(0.0);
    robots_.push_back(RobotPlan{robotName(i), aerial, start_offset, start, route,
                                std::move(trajectory), 0.0, 0.0});
  }

  // How much of each path a teammate also covered (anywhere in time).
  std::vector<std::vector<Eigen::Vector2d>> samples(robots_.size());
  for (size_t i = 0; i < robots_.size(); ++i) {
    const double active = params_.duration_s - robots_[i].start_offset_s;
    for (double t = 0.0; t <= active; t += 0.5) {
      samples[i].push_back(robots_[i].trajectory.poseAt(t).translation().head<2>());
      if (samples[i].size() > 1) {
        robots_[i].distance_m += (samples[i].back() - samples[i][samples[i].size() - 2]).norm();
      }
    }
  }
  for (size_t i = 0; i < robots_.size(); ++i) {
    int shared = 0;
    for (const auto& p : samples[i]) {
      bool near = false;
      for (size_t j = 0; j < robots_.size() && !near; ++j) {
        if (j == i) continue;
        for (const auto& q : samples[j]) {
          if ((p - q).squaredNorm() <= kSharedDistanceM * kSharedDistanceM) {
            near = true;
            break;
          }
        }
      }
      shared += near;
    }
    robots_[i].shared_fraction = samples[i].empty() ? 0.0 : double(shared) / samples[i].size();
  }
}

void Mission::record(int index, RecordingSink& sink, bool scans) const {
  const RobotPlan& robot = robots_.at(static_cast<size_t>(index));
  const Stamp begin = startStamp() + fromSeconds(robot.start_offset_s);
  const Stamp end = endStamp();
  const Stamp odom_period = fromSeconds(1.0 / params_.odometry.odom_rate_hz);
  const Stamp scan_period = fromSeconds(lidar_.sweepSeconds());
  const Pose3 odom_from_world = robot.world_from_odom.inverse();
  const Pose3 mount = sensorMount();

  OdometrySimulator odometry(params_.odometry, !robot.aerial,
                             streamSeed(params_.seed, index, kOdometryStream));
  std::mt19937_64 lidar_rng(streamSeed(params_.seed, index, kLidarStream));
  OdometrySample previous;
  for (std::int64_t k_odom = 0, k_scan = 0;;) {
    const Stamp odom_stamp = begin + k_odom * odom_period;
    const Stamp scan_stamp = begin + k_scan * scan_period;
    const Stamp published = scan_stamp + scan_period;
    const bool scan_due = published <= end;
    const bool odom_due = odom_stamp <= end;
    if (!scan_due && !odom_due) break;
    if (scan_due && (!odom_due || published <= odom_stamp)) {
      if (!scans) {
        ++k_scan;
        continue;
      }
      const double offset = toSeconds(scan_stamp - begin);
      const auto sensor_pose = [&](double t) {
        return robot.trajectory.poseAt(offset + t) * mount;
      };
      sink.scan(lidar_.scan(world_, scan_stamp, sensor_pose, lidar_rng), published);
      ++k_scan;
      continue;
    }
    OdometrySample sample;
    sample.stamp = odom_stamp;
    sample.truth = odom_from_world * robot.trajectory.poseAt(toSeconds(odom_stamp - begin));
    sample.odometry = odometry.update(sample.truth);
    sample.position_variance = odometry.positionVariance();
    sample.heading_variance = odometry.headingVariance();
    if (k_odom > 0) {
      const double dt = toSeconds(odom_stamp - previous.stamp);
      // From the true motion: a random-walk error has no meaningful derivative, and wheel
      // encoders measure speed well even when the integrated pose drifts.
      const Pose3 step = previous.truth.inverse() * sample.truth;
      sample.linear_velocity = step.translation() / dt;
      sample.yaw_rate = std::atan2(step.linear()(1, 0), step.linear()(0, 0)) / dt;
    }
    sink.odometry(sample);
    previous = sample;
    ++k_odom;
  }
}

}  // namespace ccir_mapping::core::simulation
