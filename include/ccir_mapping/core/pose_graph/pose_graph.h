// A pose graph in 2D (SE(2), poses kept planar) or 3D (SE(3)), as read from g2o files and built
// from keyframes and loop closures.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::pose_graph {

/// Information in tangent coordinates of the residual: [x y theta] (2D) or
/// [x y z, rotation vector] (3D, rotation in radians, not g2o's quaternion units).
using Information = Eigen::MatrixXd;

struct PoseGraphEdge {
  int from = 0;
  int to = 0;
  /// Pose of `to` in the frame of `from`.
  Pose3 measurement = Pose3::Identity();
  Information information;
  /// Loop closures may be wrong and get a robust treatment; odometry edges never do.
  bool loop = false;
  /// Known only for injected outliers (benchmarks, tests).
  bool outlier = false;
  /// Constant poses right-multiplied to the two ends: the edge constrains (x_from *
  /// from_offset)^-1 (x_to * to_offset). A windowed solve (core/backend/team_graph.h) moves a
  /// held stretch of a teammate's keyframes as one rigid block: one pose stands for all of them.
  Pose3 from_offset = Pose3::Identity();
  Pose3 to_offset = Pose3::Identity();

  bool hasOffsets() const {
    return !from_offset.matrix().isIdentity(0.0) || !to_offset.matrix().isIdentity(0.0);
  }
};

/// A pose's name in a multi-robot graph, written as GTSAM's symbols write it (the convention of
/// Kimera-RPGO's robot_a / robot_b graphs): the robot's letter in the top 8 bits of the 64-bit
/// vertex id, the robot's keyframe index in the other 56.
struct VertexKey {
  char robot = 'a';
  std::uint64_t index = 0;

  static constexpr int kIndexBits = 56;
  std::uint64_t id() const {
    return (std::uint64_t(static_cast<unsigned char>(robot)) << kIndexBits) | index;
  }
  /// Ids below 2^56 name no robot (robot = 0).
  static VertexKey fromId(std::uint64_t id) {
    return {static_cast<char>(id >> kIndexBits), id & ((std::uint64_t(1) << kIndexBits) - 1)};
  }
  bool operator<(const VertexKey& o) const {
    return robot != o.robot ? robot < o.robot : index < o.index;
  }
};

struct PoseGraph {
  /// 2: SE(2), every pose and measurement planar (z = 0, yaw only); 3: SE(3).
  int dimension = 3;
  /// Estimates (the initial guess until optimised).
  std::vector<Pose3> poses;
  std::vector<PoseGraphEdge> edges;
  /// A multi-robot graph's name for each pose, in increasing order (so each robot's poses are
  /// consecutive); empty for a single robot's graph, whose pose i is vertex i.
  std::vector<VertexKey> keys;

  int tangentSize() const { return dimension == 2 ? 3 : 6; }
  std::size_t loopCount() const;
};

}  // namespace ccir_mapping::core::pose_graph
