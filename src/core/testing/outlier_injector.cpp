#include "ccir_mapping/core/testing/outlier_injector.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

namespace ccir_mapping::core::testing {

std::optional<OutlierMode> parseOutlierMode(std::string_view text) {
  if (text == "random") return OutlierMode::kRandom;
  if (text == "local") return OutlierMode::kLocal;
  if (text == "grouped") return OutlierMode::kGrouped;
  return std::nullopt;
}

const char* toString(OutlierMode mode) {
  switch (mode) {
    case OutlierMode::kRandom:
      return "random";
    case OutlierMode::kLocal:
      return "local";
    default:
      return "grouped";
  }
}

void injectOutliers(pose_graph::PoseGraph& graph, const OutlierParams& params) {
  const int n = static_cast<int>(graph.poses.size());
  const int span = params.mode == OutlierMode::kGrouped ? params.group_size : 1;
  if (params.count < 0 || n < span + 3 || graph.edges.empty() || params.group_size < 1 ||
      params.local_window < 2) {
    throw std::invalid_argument("cannot inject outliers: graph too small or bad parameters");
  }
  // A pose and the span - 1 after it belong to one robot (keys are sorted: robot, then index).
  const auto same_robot_run = [&](int i) {
    return graph.keys.empty() || graph.keys[i + span - 1].robot == graph.keys[i].robot;
  };
  if (params.inter_robot) {
    // Two robots with a group's worth of poses each, or the draws below never end.
    std::map<char, int> poses_of;
    for (const pose_graph::VertexKey& key : graph.keys) ++poses_of[key.robot];
    const auto holding = std::count_if(poses_of.begin(), poses_of.end(),
                                       [&](const auto& robot) { return robot.second >= span; });
    if (params.mode == OutlierMode::kLocal || graph.keys.size() != graph.poses.size() ||
        holding < 2) {
      throw std::invalid_argument(
          "cannot inject inter-robot outliers: need a graph of two robots or more, random or "
          "grouped");
    }
  }
  pose_graph::Information information = graph.edges.front().information;
  for (const auto& e : graph.edges) {
    if (e.loop && !e.outlier) {
      information = e.information;
      break;
    }
  }
  std::mt19937_64 rng(params.seed);
  std::normal_distribution<double> translation(0.0, params.translation_sigma_m);
  std::normal_distribution<double> angle(0.0, params.angle_sigma_deg * M_PI / 180.0);
  auto measurement = [&] {
    Pose3 m = Pose3::Identity();
    m.translation().x() = translation(rng);
    m.translation().y() = translation(rng);
    if (graph.dimension == 3) m.translation().z() = translation(rng);
    const double yaw = angle(rng);
    double roll = 0.0;
    double pitch = 0.0;
    if (graph.dimension == 3) {
      roll = angle(rng);
      pitch = angle(rng);
    }
    m.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    return m;
  };
  std::uniform_int_distribution<int> any(0, n - span);
  int added = 0;
  while (added < params.count) {
    const int i = any(rng);
    int j = i;
    if (params.mode == OutlierMode::kLocal) {
      j = std::min(n - 1, i + std::uniform_int_distribution<int>(2, params.local_window)(rng));
    } else {
      j = any(rng);
    }
    if (j == i || j == i + 1 || i == j + 1 || !same_robot_run(i) || !same_robot_run(j)) continue;
    if (params.inter_robot && graph.keys[i].robot == graph.keys[j].robot) continue;
    const Pose3 m = measurement();
    for (int k = 0; k < span && added < params.count; ++k, ++added) {
      pose_graph::PoseGraphEdge edge;
      edge.from = i + k;
      edge.to = j + k;
      edge.measurement = m;
      edge.information = information;
      edge.loop = true;
      edge.outlier = true;
      graph.edges.push_back(edge);
    }
  }
}

}  // namespace ccir_mapping::core::testing
