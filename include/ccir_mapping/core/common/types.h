// Plain types shared by the ROS-free core: time, ids and poses.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include <Eigen/Geometry>

namespace ccir_mapping::core {

/// Time in nanoseconds (since the epoch or since the start of simulated time).
using Stamp = std::int64_t;

/// Keyframe id, unique per robot and increasing from 0.
using KeyframeId = std::uint64_t;

/// Rigid transform in 3D; poses are "frame expressed in parent frame".
using Pose3 = Eigen::Isometry3d;

/// Covariance of a pose, over [x y z, rotation vector].
using Matrix6 = Eigen::Matrix<double, 6, 6>;

constexpr double kNanosecondsPerSecond = 1e9;

inline double toSeconds(Stamp stamp) { return static_cast<double>(stamp) / kNanosecondsPerSecond; }
/// Rounds to the nearest nanosecond (1.025 s * 1e9 is 1024999999.99... in binary).
inline Stamp fromSeconds(double seconds) {
  return static_cast<Stamp>(std::llround(seconds * kNanosecondsPerSecond));
}

/// The unit up direction (against gravity) in a frame whose pose in a gravity-aligned frame (an
/// odometry or map frame) is `frame_pose`: what the normal filters need in the sensor frame.
inline Eigen::Vector3f upInFrame(const Pose3& frame_pose) {
  return (frame_pose.linear().transpose() * Eigen::Vector3d::UnitZ()).cast<float>();
}

/// True when every coefficient is finite and the rotation is orthonormal.
bool isValidPose(const Pose3& pose);

}  // namespace ccir_mapping::core
