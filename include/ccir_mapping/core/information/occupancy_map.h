// One robot's occupancy map (OctoMap's sensor model, voxels and file format) and the information
// questions CCIR asks of it: map entropy over a fixed box, known volume, the entropy a scan would
// remove (realised, map unchanged) and the Cauchy-Schwarz mutual information of a scan's beams
// (thesis section 3.2.3).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Core>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/information/csqmi.h"
#include "ccir_mapping/core/information/entropy_cache.h"
#include "ccir_mapping/core/information/key_bricks.h"
#include "ccir_mapping/core/information/map_information.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/information/voxel_grid.h"

namespace ccir_mapping::core::information {

/// Axis-aligned box in the map frame.
struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
};

/// The voxels one scan updates, as OctoMap's computeUpdate finds them (a voxel holding an
/// endpoint is occupied, even if another beam crossed it). Measuring and inserting use the same
/// keys, so the measured entropy drop is exactly what inserting removes.
struct ScanUpdate {
  /// Each in the octree's depth-first order (KeyBricks::inTreeOrder).
  std::vector<octomap::OcTreeKey> free;
  std::vector<octomap::OcTreeKey> occupied;
  /// Points dropped for being non-finite.
  int dropped_points = 0;
};

class OccupancyMap final : public MapInformation {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit OccupancyMap(const MapperParams& params);

  /// `points` (map frame) seen from `origin`; beams longer than max_insert_range_m clear free
  /// space up to that range only. Non-finite points are skipped and counted.
  ScanUpdate computeUpdate(const pcl::PointCloud<pcl::PointXYZ>& points,
                           const Eigen::Vector3d& origin) const;
  /// The same for a scan in its sensor frame with the sensor's pose in the map frame.
  ScanUpdate computeUpdate(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                           const Pose3& map_from_sensor) const;
  /// Applies the update with OctoMap's sensor model (p_hit 0.7, p_miss 0.4), clamped, as
  /// OcTree::updateNode would.
  void insert(const ScanUpdate& update);
  /// insert(computeUpdate(sensor_points, map_from_sensor)).
  void insert(const pcl::PointCloud<pcl::PointXYZ>& sensor_points, const Pose3& map_from_sensor);
  /// Sets each voxel to its log-odds (clamped) or makes it unknown, the entropy box following
  /// (what SubmapSet::apply computes).
  void assign(const std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>>& voxels);

  /// Entropy, in bits, inserting `update` would remove (sum over its voxels of h(before) -
  /// h(after)); may be negative where a scan contradicts the map. The map is not changed.
  double entropyReduction(const ScanUpdate& update) const;
  /// The voxels whose entropy the update lowers, with the drop.
  std::vector<VoxelGain> voxelGains(const ScanUpdate& update) const;
  /// voxelGains(computeUpdate(sensor_points, map_from_sensor)).
  std::vector<VoxelGain> scanGains(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                   const Pose3& map_from_sensor) const override;
  std::vector<VoxelGain> scanFootprint(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                       const Pose3& map_from_sensor) const override;

  /// Sum of voxel entropies in the box, in bits; an unknown voxel has 1 bit. Walks the box.
  double entropyBits(const Box& box) const;
  /// Volume of the box's known voxels, m^3. Walks the box.
  double knownVolumeM3(const Box& box) const;
  /// The same two for the entropy box of the parameters, kept up to date by every insertion
  /// (what MapStats reports every publish_period_s, at no cost).
  double boxEntropyBits() const { return box_entropy_bits_; }
  double boxKnownVolumeM3() const;

  /// CSQMI (nats) of beams from `origin` along each of `directions` (map frame, any length) up
  /// to max_insert_range_m, summed: what a measurement there could tell about the map.
  double beamsCsqmi(const Eigen::Vector3d& origin,
                    const std::vector<Eigen::Vector3d>& directions) const;
  /// Mutual information of a scan before inserting it: beams towards every scan_beam_step-th
  /// point. About 0 where the map already knows what the scan sees.
  double scanCsqmi(const pcl::PointCloud<pcl::PointXYZ>& points,
                   const Eigen::Vector3d& origin) const;
  /// Mutual information of a simulated VLP-16 measurement at `sensor_pose` (map frame): 16
  /// rings from -15 to +15 degrees, a beam every simulated_azimuth_step_deg.
  double simulatedCsqmi(const Pose3& sensor_pose) const override;
  /// The cells one beam crosses (for beamsCsqmi and tests).
  BeamCells beamCells(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;

  /// Centres of the occupied voxels, map frame.
  pcl::PointCloud<pcl::PointXYZ> occupiedCentres() const;

  /// Occupancy probability of the voxel holding `key` (0.5 if unknown).
  double occupancy(const octomap::OcTreeKey& key) const;
  /// The geometry of the map's keys (resolution, key <-> coordinate, ray keys) and its sensor
  /// model; an OcTree that holds no voxel (voxels() does).
  const octomap::OcTree& grid() const { return grid_; }
  const VoxelGrid<float>& voxels() const { return voxels_; }
  const MapperParams& params() const { return params_; }
  /// Writes the map as a binary OctoMap (.bt), pruned; false if the file cannot be written.
  /// The tree is built in the voxels' order and pruned as it grows, so it never holds much
  /// more than the pruned map.
  bool save(const std::string& path) const;
  /// Replaces the map with one save() wrote. A binary OctoMap keeps only free or occupied, so
  /// each voxel comes back at its clamping bound. Throws std::runtime_error naming the file
  /// when it cannot be read, is not a binary OctoMap, or has another resolution than
  /// resolution_m.
  void load(const std::string& path);

 private:
  /// Log-odds of the voxel after one hit or miss, as OccupancyOcTreeBase::updateNode does it.
  float updatedLogOdds(float log_odds, bool hit) const;
  /// Within the clamping bounds.
  float clamped(float log_odds) const;
  /// h(before) - h(after) of one voxel for one hit or miss.
  double entropyDrop(const octomap::OcTreeKey& key, bool hit) const;

  /// The voxels `points` (map frame) seen from `origin` update; returns the non-finite points.
  int collect(const pcl::PointCloud<pcl::PointXYZ>& points, const Eigen::Vector3d& origin,
              KeyBricks& free_cells, KeyBricks& occupied_cells) const;
  /// One voxel's hit or miss, with the entropy box's statistics following it.
  void update(const octomap::OcTreeKey& key, bool hit);
  bool inBox(const octomap::OcTreeKey& key) const;

  MapperParams params_;
  octomap::OcTree grid_;
  VoxelGrid<float> voxels_;
  octomap::OcTreeKey box_min_key_;
  octomap::OcTreeKey box_max_key_;
  double box_entropy_bits_ = 0.0;
  double box_known_voxels_ = 0.0;
  EntropyCache entropy_;
};

/// Binary entropy, in bits, of an occupancy probability.
double occupancyEntropyBits(double p);

}  // namespace ccir_mapping::core::information
