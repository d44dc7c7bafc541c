// g2o text files: VERTEX_SE2 / EDGE_SE2 and VERTEX_SE3:QUAT / EDGE_SE3:QUAT.
#pragma once

#include <string>

#include "ccir_mapping/core/backend/pose_graph.h"

namespace ccir_mapping::core::backend {

/// Reads a g2o file. Edges between consecutive ids are odometry (the first one of a pair;
/// repeated pairs are loops), all others loop closures. A graph without vertex lines gets its
/// initial poses by chaining the odometry. EDGE_SE3:QUAT information refers to
/// [t, qx, qy, qz] (qx ~ theta / 2): it is converted to the rotation-vector units of the
/// residual (rotation block / 4, cross blocks / 2). Throws std::runtime_error naming the file and
/// line on anything else.
PoseGraph readG2o(const std::string& path);

/// Writes the graph back in g2o conventions (inverse of readG2o, up to float formatting).
void writeG2o(const PoseGraph& graph, const std::string& path);

/// Ground-truth poses: lines "[id] x y theta" (2D) or "[id] x y z qx qy qz qw" (3D); '#' comments.
std::vector<Pose3> readGroundTruth(const std::string& path, int dimension);

}  // namespace ccir_mapping::core::backend
