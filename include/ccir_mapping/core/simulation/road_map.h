// The free lanes of a simulated world as a graph: robots drive along its edges.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace ccir_mapping::core::simulation {

/// Undirected graph whose nodes are points on the floor and whose edges are straight lanes with
/// room to drive (drift centrelines, corridors, tunnel centrelines).
class RoadMap {
 public:
  int addNode(const Eigen::Vector2d& position);
  void addEdge(int a, int b);

  int nodeCount() const { return static_cast<int>(nodes_.size()); }
  int edgeCount() const { return edge_count_; }
  const Eigen::Vector2d& node(int i) const { return nodes_[i]; }
  const std::vector<int>& neighbours(int i) const { return neighbours_[i]; }

 private:
  std::vector<Eigen::Vector2d> nodes_;
  std::vector<std::vector<int>> neighbours_;
  int edge_count_ = 0;
};

}  // namespace ccir_mapping::core::simulation
