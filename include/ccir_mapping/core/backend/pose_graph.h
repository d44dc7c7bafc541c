// A pose graph in 2D (SE(2), poses kept planar) or 3D (SE(3)), as read from g2o files and built
// from keyframes and loop closures.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::backend {

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
};

struct PoseGraph {
  /// 2: SE(2), every pose and measurement planar (z = 0, yaw only); 3: SE(3).
  int dimension = 3;
  /// Estimates (the initial guess until optimised).
  std::vector<Pose3> poses;
  std::vector<PoseGraphEdge> edges;

  int tangentSize() const { return dimension == 2 ? 3 : 6; }
  std::size_t loopCount() const;
};

}  // namespace ccir_mapping::core::backend
