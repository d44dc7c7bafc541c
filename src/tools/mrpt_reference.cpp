#include "mrpt_reference.h"

#include <chrono>
#include <stdexcept>

#include <mrpt/containers/yaml.h>
#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/graphslam/levmarq.h>
#include <mrpt/math/CMatrixFixed.h>
#include <Eigen/Geometry>

namespace {

template <class Graph>
MrptReference optimise(const std::string& path, int max_iterations) {
  Graph graph;
  try {
    graph.loadFromTextFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error("MRPT cannot read " + path + ": " + e.what());
  }
  graph.root = 0;
  mrpt::graphslam::TResultInfoSpaLevMarq info;
  mrpt::containers::yaml params = mrpt::containers::yaml::Map();
  params["max_iterations"] = max_iterations;
  const auto start = std::chrono::steady_clock::now();
  mrpt::graphslam::optimize_graph_spa_levmarq(graph, info, nullptr, params);
  MrptReference result;
  result.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.iterations = static_cast<int>(info.num_iters);
  for (const auto& [id, node] : graph.nodes) {
    const auto matrix = node.template getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
    ccir_mapping::core::Pose3 pose = ccir_mapping::core::Pose3::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) pose.matrix()(r, c) = matrix(r, c);
    }
    if (result.poses.size() <= id)
      result.poses.resize(id + 1, ccir_mapping::core::Pose3::Identity());
    result.poses[id] = pose;
  }
  return result;
}

}  // namespace

MrptReference runMrptReference(const std::string& g2o, int dimension, int max_iterations) {
  return dimension == 2 ? optimise<mrpt::graphs::CNetworkOfPoses2DInf>(g2o, max_iterations)
                        : optimise<mrpt::graphs::CNetworkOfPoses3DInf>(g2o, max_iterations);
}
