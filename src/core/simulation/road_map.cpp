#include "ccir_mapping/core/simulation/road_map.h"

#include <algorithm>
#include <stdexcept>

namespace ccir_mapping::core::simulation {

int RoadMap::addNode(const Eigen::Vector2d& position) {
  nodes_.push_back(position);
  neighbours_.emplace_back();
  return nodeCount() - 1;
}

void RoadMap::addEdge(int a, int b) {
  if (a == b || a < 0 || b < 0 || a >= nodeCount() || b >= nodeCount()) {
    throw std::out_of_range("RoadMap::addEdge: bad node index");
  }
  auto& from_a = neighbours_[a];
  if (std::find(from_a.begin(), from_a.end(), b) != from_a.end()) return;
  from_a.push_back(b);
  neighbours_[b].push_back(a);
  ++edge_count_;
}

}  // namespace ccir_mapping::core::simulation
