// Scan Context (Kim & Kim, "Scan Context: Egocentric Spatial Descriptor for Place Recognition
// within 3D Point Cloud Map", IROS 2018): a scan as a rings x sectors polar grid around the
// sensor holding the highest point of each bin, a rotation-invariant ring key (each ring's share
// of occupied bins) to find candidates, a sector key (each sector's mean height) to guess the yaw
// shift, and the column-shift cosine distance that compares two descriptors at their best yaw.
// Written here from the paper: no Debian package provides it.
#pragma once

#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Core>

namespace ccir_mapping::core::place_recognition {

struct ScanContextParams {
  /// Radial bins out to max_range_m (the paper: 20 rings to 80 m outdoors; a mine drift is
  /// seen to ~30 m).
  int rings = 20;
  int sectors = 60;
  double max_range_m = 30.0;
  /// Heights are stored as z + this, so that the floor (z ~ -sensor height) counts as occupied
  /// and an empty bin (0) stays apart from a low one.
  double height_offset_m = 2.0;
  /// Places whose ring key is nearest the query's are compared in full (the paper: 10).
  int ring_key_candidates = 10;
  /// Column shifts tried on each side of the one the sector keys suggest, as a share of the
  /// sectors (0.5: every shift).
  double shift_search_share = 0.1;

  std::vector<std::string> validate() const;
};

class ScanContext {
 public:
  /// The descriptor of `points` in a gravity-aligned sensor frame (z up); non-finite points and
  /// points beyond max_range_m are left out. Throws std::invalid_argument on invalid params.
  ScanContext(const pcl::PointCloud<pcl::PointXYZ>& points, const ScanContextParams& params);

  /// rings x sectors; sector 0 starts at azimuth -180 degrees.
  const Eigen::MatrixXf& descriptor() const { return descriptor_; }
  /// Per ring, the share of its sectors holding a point.
  const Eigen::VectorXf& ringKey() const { return ring_key_; }
  /// Per sector, the mean height over the rings.
  const Eigen::VectorXf& sectorKey() const { return sector_key_; }

 private:
  Eigen::MatrixXf descriptor_;
  Eigen::VectorXf ring_key_;
  Eigen::VectorXf sector_key_;
};

/// How two descriptors compare at their best alignment: the mean cosine distance of their
/// columns (over the columns occupied in both; 1 when none is) when column j of `a` meets column
/// j + shift of `b` (0: the same place); yaw_rad is then the heading of b's sensor frame in a's
/// (a direction at azimuth phi from a is at phi - yaw_rad from b), to a sector.
struct ScanContextDistance {
  double distance = 1.0;
  int shift = 0;
  double yaw_rad = 0.0;
};

/// Tries the shifts within shift_search_share x sectors of the one the sector keys suggest (all
/// of them at 0.5). Throws std::invalid_argument when the two grids differ.
ScanContextDistance scanContextDistance(const ScanContext& a, const ScanContext& b,
                                        const ScanContextParams& params);

}  // namespace ccir_mapping::core::place_recognition
