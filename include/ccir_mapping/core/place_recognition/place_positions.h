// A spatial index of place positions in one odometry frame, grown one place at a time: the
// places a pose gate admits are found by a radius search instead of a pass over all places.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace ccir_mapping::core::place_recognition {

class PlacePositions {
 public:
  PlacePositions();
  ~PlacePositions();
  PlacePositions(PlacePositions&&) noexcept;
  PlacePositions& operator=(PlacePositions&&) noexcept;

  /// The place `index` (the caller's numbering) is at `position`.
  void add(std::size_t index, const Eigen::Vector3d& position);
  /// The places within radius_m of centre, in no particular order.
  std::vector<std::size_t> within(const Eigen::Vector3d& centre, double radius_m) const;
  std::size_t size() const;

 private:
  struct Index;
  std::unique_ptr<Index> index_;
};

}  // namespace ccir_mapping::core::place_recognition
