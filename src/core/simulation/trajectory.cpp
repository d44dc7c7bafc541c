#include "ccir_mapping/core/simulation/trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

namespace ccir_mapping::core::simulation {
namespace {

Eigen::Vector2d unit(double heading) { return {std::cos(heading), std::sin(heading)}; }
double headingOf(const Eigen::Vector2d& v) { return std::atan2(v.y(), v.x()); }

}  // namespace

Trajectory::Trajectory(const std::vector<Eigen::Vector2d>& waypoints,
                       const TrajectoryParams& params, HeightAt height)
    : params_(params), height_(std::move(height)) {
  if (!(params.speed_mps > 0.0) || !(params.turn_rate_rad_per_s > 0.0) ||
      !(params.turn_radius_m >= 0.0)) {
    throw std::invalid_argument("Trajectory: speed and turn rate must be > 0, radius >= 0");
  }
  std::vector<Eigen::Vector2d> points;
  for (const auto& w : waypoints) {
    if (points.empty() || (w - points.back()).norm() > 1e-6) points.push_back(w);
  }
  if (points.size() < 2) throw std::invalid_argument("Trajectory: needs two distinct waypoints");

  Eigen::Vector2d position = points[0];
  for (size_t i = 1; i < points.size(); ++i) {
    const Eigen::Vector2d corner = points[i];
    if (i + 1 == points.size()) {
      addLine(position, corner);
      break;
    }
    const Eigen::Vector2d in = (corner - points[i - 1]).normalized();
    const Eigen::Vector2d out = (points[i + 1] - corner).normalized();
    const double angle = std::atan2(in.x() * out.y() - in.y() * out.x(), in.dot(out));
    if (std::abs(angle) < 1e-6) continue;  // straight on: the next line starts at `position`
    if (std::abs(angle) > kSpotTurnRad || params.turn_radius_m == 0.0) {
      addLine(position, corner);
      addSpin(corner, headingOf(in), angle);
      position = corner;
      continue;
    }
    // Tangent points at `cut` before and after the corner; shrink the arc where the lanes are
    // short (leave half of the next lane to its far corner).
    const double half_tan = std::tan(0.5 * std::abs(angle));
    const double cut = std::min({params.turn_radius_m * half_tan, (corner - position).norm(),
                                 0.5 * (points[i + 1] - corner).norm()});
    const Eigen::Vector2d enter = corner - cut * in;
    addLine(position, enter);
    addArc(enter, headingOf(in), std::copysign(cut / half_tan, angle), angle);
    position = corner + cut * out;
  }
}

void Trajectory::addLine(const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  const double length = (to - from).norm();
  if (length < 1e-9) return;
  const double start = endTime();
  segments_.push_back({Segment::Kind::kLine, start, start + length / params_.speed_mps, from,
                       headingOf(to - from), length, 0.0});
  length_m_ += length;
}

void Trajectory::addArc(const Eigen::Vector2d& from, double heading, double radius, double angle) {
  const double length = std::abs(radius * angle);
  if (length < 1e-9) return;
  const double start = endTime();
  const Eigen::Vector2d center =
      from + radius * Eigen::Vector2d(-std::sin(heading), std::cos(heading));
  segments_.push_back({Segment::Kind::kArc, start, start + length / params_.speed_mps, center,
                       heading, length, radius});
  length_m_ += length;
}

void Trajectory::addSpin(const Eigen::Vector2d& at, double heading, double angle) {
  const double start = endTime();
  segments_.push_back({Segment::Kind::kSpin, start,
                       start + std::abs(angle) / params_.turn_rate_rad_per_s, at, heading, angle,
                       0.0});
}

Pose3 Trajectory::poseAt(double t) const {
  t = std::clamp(t, 0.0, durationS());
  auto it = std::lower_bound(segments_.begin(), segments_.end(), t,
                             [](const Segment& s, double time) { return s.end_s < time; });
  if (it == segments_.end()) it = std::prev(segments_.end());
  const Segment& s = *it;
  const double fraction = s.end_s > s.start_s ? (t - s.start_s) / (s.end_s - s.start_s) : 1.0;

  Eigen::Vector2d xy;
  double yaw = s.heading;
  switch (s.kind) {
    case Segment::Kind::kLine:
      xy = s.start + fraction * s.length * unit(s.heading);
      break;
    case Segment::Kind::kArc:
      yaw = s.heading + fraction * s.length / s.radius;
      xy = s.start + s.radius * Eigen::Vector2d(std::sin(yaw), -std::cos(yaw));
      break;
    case Segment::Kind::kSpin:
      xy = s.start;
      yaw = s.heading + fraction * s.length;
      break;
  }
  Pose3 pose = Pose3::Identity();
  pose.translation() << xy.x(), xy.y(), height_ ? height_(t) : 0.0;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

}  // namespace ccir_mapping::core::simulation
