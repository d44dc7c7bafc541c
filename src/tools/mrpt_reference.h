// MRPT's pose-graph optimiser (Levenberg-Marquardt, graphslam) on a g2o file: the reference
// pgo_benchmark compares the Ceres back end with.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"

struct MrptReference {
  std::vector<ccir_mapping::core::Pose3> poses;  // by node id
  double solve_s = 0.0;
  int iterations = 0;
};

/// Loads `g2o` into MRPT's CNetworkOfPoses2DInf / 3DInf and optimises it. Throws
/// std::runtime_error when MRPT cannot read the file.
MrptReference runMrptReference(const std::string& g2o, int dimension, int max_iterations);
