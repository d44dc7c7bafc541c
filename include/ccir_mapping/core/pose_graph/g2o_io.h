// g2o text files: VERTEX_SE2 / EDGE_SE2 and VERTEX_SE3:QUAT / EDGE_SE3:QUAT, one robot's (vertex
// ids 0..n-1) or a team's (robot-keyed ids, see VertexKey), with switchable loop closures in
// Vertigo's notation (VERTEX_SWITCH, EDGE_SWITCH_PRIOR, EDGE_SE2/SE3_SWITCHABLE).
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/pose_graph/pose_graph.h"

namespace ccir_mapping::core::pose_graph {

/// Reads a g2o file. In a file with switchable edges those are the loop closures and the plain
/// edges odometry (switch values are not read: the optimiser finds its own); otherwise edges
/// between consecutive ids (of one robot) are odometry (the first one of a pair; repeated pairs
/// are loops), all others loop closures. Robot-keyed ids fill graph.keys
/// and need a vertex line each; a single robot's graph without vertex lines gets its initial
/// poses by chaining the odometry. EDGE_SE3:QUAT information refers to
/// [t, qx, qy, qz] (qx ~ theta / 2): it is converted to the rotation-vector units of the
/// residual (rotation block / 4, cross blocks / 2). Throws std::runtime_error naming the file and
/// line on anything else.
PoseGraph readG2o(const std::string& path);

/// Writes the graph back in g2o conventions (inverse of readG2o, up to float formatting), with
/// graph.keys as vertex ids when there are keys. With one weight per edge (an optimiser's
/// switch values), loop closures are written as switchable edges with their switch's value.
void writeG2o(const PoseGraph& graph, const std::string& path,
              const std::vector<double>& loop_weights = {});

/// Ground-truth poses: lines "[id] x y theta" (2D) or "[id] x y z qx qy qz qw" (3D); '#' comments.
std::vector<Pose3> readGroundTruth(const std::string& path, int dimension);

}  // namespace ccir_mapping::core::pose_graph
