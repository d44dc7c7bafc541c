// A robot's true motion: a path through the road map driven at constant speed, corners rounded
// by arcs, sharp turns made on the spot, and a height profile.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::simulation {

struct TrajectoryParams {
  double speed_mps = 1.0;
  /// Corners are rounded with arcs of this radius (shrunk where lanes are short); turns sharper
  /// than kSpotTurnRad are made on the spot.
  double turn_radius_m = 1.0;
  double turn_rate_rad_per_s = 0.8;
};

class Trajectory {
 public:
  static constexpr double kSpotTurnRad = 150.0 * 3.14159265358979323846 / 180.0;
  /// Height of base_link above the floor at time t (seconds since the start).
  using HeightAt = std::function<double(double t)>;

  /// `waypoints` is the polyline to follow (at least two distinct points).
  Trajectory(const std::vector<Eigen::Vector2d>& waypoints, const TrajectoryParams& params,
             HeightAt height);

  /// Pose of base_link in the world t seconds after the start (level, heading along the path);
  /// before the start and after the end the robot stands at the first or last pose.
  Pose3 poseAt(double t) const;
  double durationS() const { return segments_.empty() ? 0.0 : segments_.back().end_s; }
  double lengthM() const { return length_m_; }

 private:
  struct Segment {
    enum class Kind { kLine, kArc, kSpin } kind;
    double start_s, end_s;
    Eigen::Vector2d start;  // line start or spin position; arc centre
    double heading;         // at the start of the segment
    double length;          // line or arc length; signed angle for spins
    double radius;          // arcs; signed: positive turns left
  };
  void addLine(const Eigen::Vector2d& from, const Eigen::Vector2d& to);
  void addArc(const Eigen::Vector2d& from, double heading, double radius, double angle);
  void addSpin(const Eigen::Vector2d& at, double heading, double angle);
  double endTime() const { return segments_.empty() ? 0.0 : segments_.back().end_s; }

  TrajectoryParams params_;
  HeightAt height_;
  std::vector<Segment> segments_;
  double length_m_ = 0.0;
};

}  // namespace ccir_mapping::core::simulation
