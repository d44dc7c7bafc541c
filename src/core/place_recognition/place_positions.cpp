#include "ccir_mapping/core/place_recognition/place_positions.h"

// nanoflann's dynamic tree copies a bounding box GCC cannot prove set before its first point;
// it is (addPoints computes it), so the warning is silenced for this file.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <nanoflann.hpp>

namespace ccir_mapping::core::place_recognition {

/// nanoflann's dynamic kd-tree (a forest of static trees, so that adding stays O(log n)
/// amortised) over the positions, which it reads through the adaptor interface below.
struct PlacePositions::Index {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::size_t> places;  // the caller's index of each point

  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }

  using Tree =
      nanoflann::KDTreeSingleIndexDynamicAdaptor<nanoflann::L2_Simple_Adaptor<double, Index>, Index,
                                                 3, std::size_t>;
  Tree tree{3, *this, nanoflann::KDTreeSingleIndexAdaptorParams(10)};
};

PlacePositions::PlacePositions() : index_(std::make_unique<Index>()) {}
PlacePositions::~PlacePositions() = default;
PlacePositions::PlacePositions(PlacePositions&&) noexcept = default;
PlacePositions& PlacePositions::operator=(PlacePositions&&) noexcept = default;

void PlacePositions::add(std::size_t index, const Eigen::Vector3d& position) {
  index_->points.push_back(position);
  index_->places.push_back(index);
  const std::size_t added = index_->points.size() - 1;
  index_->tree.addPoints(added, added);
}

std::vector<std::size_t> PlacePositions::within(const Eigen::Vector3d& centre,
                                                double radius_m) const {
  std::vector<std::pair<std::size_t, double>> matches;
  nanoflann::RadiusResultSet<double, std::size_t> result(radius_m * radius_m, matches);
  index_->tree.findNeighbors(result, centre.data(), nanoflann::SearchParams());
  std::vector<std::size_t> places;
  places.reserve(matches.size());
  for (const auto& match : matches) places.push_back(index_->places[match.first]);
  return places;
}

std::size_t PlacePositions::size() const { return index_->points.size(); }

}  // namespace ccir_mapping::core::place_recognition
