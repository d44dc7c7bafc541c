#include "ccir_mapping/core/information/occupancy_map.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include <pcl/common/transforms.h>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::information {
namespace {

octomap::point3d toOctomap(const Eigen::Vector3d& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}

/// As OctoMap computes it (in double).
double probability(double log_odds) { return 1.0 - 1.0 / (1.0 + std::exp(log_odds)); }

}  // namespace

double occupancyEntropyBits(double p) {
  if (p <= 0.0 || p >= 1.0) return 0.0;
  return -p * std::log2(p) - (1 - p) * std::log2(1 - p);
}

double EntropyCache::entropyOf(float log_odds) {
  return occupancyEntropyBits(probability(log_odds));
}

OccupancyMap::OccupancyMap(const MapperParams& params)
    : params_(validated(params)), grid_(params.resolution_m) {
  grid_.setClampingThresMin(params_.occupancy_clamp_min);
  grid_.setClampingThresMax(params_.occupancy_clamp_max);
  // validate() checked that the box lies within OctoMap's reach.
  grid_.coordToKeyChecked(toOctomap(params_.entropyBoxMin()), box_min_key_);
  grid_.coordToKeyChecked(toOctomap(params_.entropyBoxMax()), box_max_key_);
  box_entropy_bits_ = 1.0;
  for (int a = 0; a < 3; ++a) box_entropy_bits_ *= box_max_key_[a] - box_min_key_[a] + 1;
}

double OccupancyMap::boxKnownVolumeM3() const {
  return box_known_voxels_ * std::pow(params_.resolution_m, 3);
}

bool OccupancyMap::inBox(const octomap::OcTreeKey& key) const {
  bool in_box = true;
  for (int a = 0; a < 3; ++a) in_box &= key[a] >= box_min_key_[a] && key[a] <= box_max_key_[a];
  return in_box;
}

void OccupancyMap::update(const octomap::OcTreeKey& key, bool hit) {
  bool created = false;
  float& log_odds = voxels_.at(key, created);
  const bool in_box = inBox(key);
  const double h_before = !in_box ? 0.0 : created ? 1.0 : entropy_(log_odds);
  log_odds = updatedLogOdds(log_odds, hit);
  if (in_box) {
    box_known_voxels_ += created ? 1.0 : 0.0;
    box_entropy_bits_ += entropy_(log_odds) - h_before;
  }
}

void OccupancyMap::assign(
    const std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>>& voxels) {
  for (const auto& [key, log_odds] : voxels) {
    if (inBox(key)) {
      const float* before = voxels_.find(key);
      box_entropy_bits_ +=
          (log_odds ? entropy_(clamped(*log_odds)) : 1.0) - (before ? entropy_(*before) : 1.0);
      box_known_voxels_ += (log_odds ? 1.0 : 0.0) - (before ? 1.0 : 0.0);
    }
    if (!log_odds) {
      voxels_.erase(key);
      continue;
    }
    bool created = false;
    voxels_.at(key, created) = clamped(*log_odds);
  }
}

int OccupancyMap::collect(const pcl::PointCloud<pcl::PointXYZ>& points,
                          const Eigen::Vector3d& origin, KeyBricks& free_cells,
                          KeyBricks& occupied_cells) const {
  if (!origin.allFinite()) throw std::invalid_argument("computeUpdate: non-finite sensor origin");
  // OccupancyOcTreeBase::computeUpdate's rule, into flat sets: a beam frees the cells it
  // crosses up to max_insert_range_m and occupies its endpoint if within it; an endpoint wins
  // over a crossing.
  int dropped = 0;
  const octomap::point3d from = toOctomap(origin);
  const auto max_range = static_cast<float>(params_.max_insert_range_m);
  octomap::KeyRay ray;
  for (const auto& p : points) {
    if (!p.getVector3fMap().allFinite()) {
      ++dropped;
      continue;
    }
    octomap::point3d end(p.x, p.y, p.z);
    const float range = (end - from).norm();
    const bool hit = range <= max_range;
    if (!hit) end = from + (end - from) * (max_range / range);
    if (grid_.computeRayKeys(from, end, ray)) {
      for (const auto& key : ray) free_cells.insert(key);
    }
    octomap::OcTreeKey key;
    if (hit && grid_.coordToKeyChecked(end, key)) occupied_cells.insert(key);
  }
  return dropped;
}

ScanUpdate OccupancyMap::computeUpdate(const pcl::PointCloud<pcl::PointXYZ>& points,
                                       const Eigen::Vector3d& origin) const {
  ScanUpdate update;
  KeyBricks free_cells;
  KeyBricks occupied_cells;
  update.dropped_points = collect(points, origin, free_cells, occupied_cells);
  // In the tree's order: reproducible, and what insert() walks fastest.
  update.free = free_cells.inTreeOrder(&occupied_cells);
  update.occupied = occupied_cells.inTreeOrder();
  return update;
}

ScanUpdate OccupancyMap::computeUpdate(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                       const Pose3& map_from_sensor) const {
  if (!map_from_sensor.matrix().allFinite()) {
    throw std::invalid_argument("computeUpdate: non-finite sensor pose");
  }
  pcl::PointCloud<pcl::PointXYZ> map_points;
  pcl::transformPointCloud(sensor_points, map_points, map_from_sensor.matrix().cast<float>());
  return computeUpdate(map_points, map_from_sensor.translation());
}

pcl::PointCloud<pcl::PointXYZ> OccupancyMap::occupiedCentres() const {
  pcl::PointCloud<pcl::PointXYZ> centres;
  const float occupied = grid_.getOccupancyThresLog();  // as OcTree::isNodeOccupied
  voxels_.forEach([&](const octomap::OcTreeKey& key, float log_odds) {
    if (log_odds < occupied) return;
    const octomap::point3d c = grid_.keyToCoord(key);
    centres.push_back(pcl::PointXYZ(c.x(), c.y(), c.z()));
  });
  return centres;
}

void OccupancyMap::insert(const ScanUpdate& scan) {
  for (const auto& key : scan.free) update(key, false);
  for (const auto& key : scan.occupied) update(key, true);
}

void OccupancyMap::insert(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                          const Pose3& map_from_sensor) {
  insert(computeUpdate(sensor_points, map_from_sensor));
}

float OccupancyMap::updatedLogOdds(float log_odds, bool hit) const {
  return clamped(log_odds + (hit ? grid_.getProbHitLog() : grid_.getProbMissLog()));
}

float OccupancyMap::clamped(float log_odds) const {
  return std::clamp(log_odds, grid_.getClampingThresMinLog(), grid_.getClampingThresMaxLog());
}

double OccupancyMap::occupancy(const octomap::OcTreeKey& key) const {
  const float* log_odds = voxels_.find(key);
  return log_odds ? probability(*log_odds) : 0.5;
}

double OccupancyMap::entropyDrop(const octomap::OcTreeKey& key, bool hit) const {
  const float* log_odds = voxels_.find(key);
  const float before = log_odds ? *log_odds : 0.0F;
  return occupancyEntropyBits(probability(before)) -
         occupancyEntropyBits(probability(updatedLogOdds(before, hit)));
}

std::vector<VoxelGain> OccupancyMap::scanGains(const pcl::PointCloud<pcl::PointXYZ>& sensor_points,
                                               const Pose3& map_from_sensor) const {
  return voxelGains(computeUpdate(sensor_points, map_from_sensor));
}

std::vector<VoxelGain> OccupancyMap::scanFootprint(
    const pcl::PointCloud<pcl::PointXYZ>& sensor_points, const Pose3& map_from_sensor) const {
  pcl::PointCloud<pcl::PointXYZ> beams;
  for (std::size_t i = 0; i < sensor_points.size();
       i += static_cast<std::size_t>(params_.scan_beam_step)) {
    beams.push_back(sensor_points[i]);
  }
  const ScanUpdate update = computeUpdate(beams, map_from_sensor);
  const auto prior = [this](bool hit) {
    return static_cast<float>(1.0 - occupancyEntropyBits(probability(updatedLogOdds(0.0F, hit))));
  };
  std::vector<VoxelGain> gains;
  gains.reserve(update.free.size() + update.occupied.size());
  for (const auto& key : update.free) gains.emplace_back(key, prior(false));
  for (const auto& key : update.occupied) gains.emplace_back(key, prior(true));
  return gains;
}

std::vector<VoxelGain> OccupancyMap::voxelGains(const ScanUpdate& update) const {
  std::vector<VoxelGain> gains;
  gains.reserve(update.free.size() + update.occupied.size());
  for (const bool hit : {false, true}) {
    for (const auto& key : hit ? update.occupied : update.free) {
      const double drop = entropyDrop(key, hit);
      if (drop > 0) gains.emplace_back(key, static_cast<float>(drop));
    }
  }
  return gains;
}

double OccupancyMap::entropyReduction(const ScanUpdate& update) const {
  double total = 0.0;
  for (const auto& key : update.free) total += entropyDrop(key, false);
  for (const auto& key : update.occupied) total += entropyDrop(key, true);
  return total;
}

namespace {

/// The keys of the box's corners, or nothing where it leaves OctoMap's reach.
std::optional<std::pair<octomap::OcTreeKey, octomap::OcTreeKey>> boxKeys(
    const octomap::OcTree& grid, const Box& box) {
  octomap::OcTreeKey min_key;
  octomap::OcTreeKey max_key;
  if (!grid.coordToKeyChecked(toOctomap(box.min), min_key) ||
      !grid.coordToKeyChecked(toOctomap(box.max), max_key)) {
    return std::nullopt;
  }
  return std::pair(min_key, max_key);
}

}  // namespace

double OccupancyMap::entropyBits(const Box& box) const {
  const auto keys = boxKeys(grid_, box);
  if (!keys) return 0.0;
  double voxels = 1.0;
  for (int a = 0; a < 3; ++a) voxels *= std::max(0, keys->second[a] - keys->first[a] + 1);
  double known = 0.0;
  double bits = 0.0;
  voxels_.forEachIn(keys->first, keys->second, [&](const octomap::OcTreeKey&, float log_odds) {
    known += 1.0;
    bits += occupancyEntropyBits(probability(log_odds));
  });
  return bits + (voxels - known);
}

double OccupancyMap::knownVolumeM3(const Box& box) const {
  const auto keys = boxKeys(grid_, box);
  if (!keys) return 0.0;
  double known = 0.0;
  voxels_.forEachIn(keys->first, keys->second,
                    [&](const octomap::OcTreeKey&, float) { known += 1.0; });
  return known * std::pow(params_.resolution_m, 3);
}

BeamCells OccupancyMap::beamCells(const Eigen::Vector3d& origin,
                                  const Eigen::Vector3d& direction) const {
  BeamCells beam;
  beam.max_range_m = params_.max_insert_range_m;
  const Eigen::Vector3d unit = direction.normalized();
  // Later cells matter only while the beam may still be unobstructed, which most beams stop
  // being within metres: the ray is traced in segments (computeRayKeys has no early exit). A
  // segment holds its start's voxel and not its end's, so the segments' keys are the ray's.
  constexpr double kNegligible = 1e-4;
  constexpr double kSegmentM = 1.0;
  double all_free = 1.0;
  octomap::KeyRay ray;
  for (double from = 0.0; from < beam.max_range_m; from += kSegmentM) {
    const double to = std::min(beam.max_range_m, from + kSegmentM);
    if (!grid_.computeRayKeys(toOctomap(origin + unit * from), toOctomap(origin + unit * to),
                              ray)) {
      return beam;
    }
    for (const auto& key : ray) {
      const double o = occupancy(key);
      const octomap::point3d c = grid_.keyToCoord(key);
      beam.occupancy.push_back(o);
      beam.range_m.push_back((Eigen::Vector3d(c.x(), c.y(), c.z()) - origin).norm());
      all_free *= 1.0 - o;
      if (all_free < kNegligible) return beam;
    }
  }
  return beam;
}

double OccupancyMap::beamsCsqmi(const Eigen::Vector3d& origin,
                                const std::vector<Eigen::Vector3d>& directions) const {
  double total = 0.0;
  for (const auto& d : directions) total += beamCsqmi(beamCells(origin, d), params_.csqmi_sigma_m);
  return total;
}

double OccupancyMap::scanCsqmi(const pcl::PointCloud<pcl::PointXYZ>& points,
                               const Eigen::Vector3d& origin) const {
  std::vector<Eigen::Vector3d> directions;
  for (std::size_t i = 0; i < points.size();
       i += static_cast<std::size_t>(params_.scan_beam_step)) {
    const Eigen::Vector3d d = points[i].getVector3fMap().cast<double>() - origin;
    if (d.allFinite() && d.norm() > 1e-6) directions.push_back(d);
  }
  return beamsCsqmi(origin, directions);
}

double OccupancyMap::simulatedCsqmi(const Pose3& sensor_pose) const {
  if (!sensor_pose.matrix().allFinite()) {
    throw std::invalid_argument("simulatedCsqmi: non-finite sensor pose");
  }
  std::vector<Eigen::Vector3d> directions;
  const double step = params_.simulated_azimuth_step_deg * M_PI / 180;
  for (int ring = 0; ring < 16; ++ring) {
    const double elevation = (-15.0 + 2.0 * ring) * M_PI / 180;
    for (double azimuth = 0; azimuth < 2 * M_PI - 1e-9; azimuth += step) {
      directions.push_back(sensor_pose.linear() *
                           Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                           std::cos(elevation) * std::sin(azimuth),
                                           std::sin(elevation)));
    }
  }
  return beamsCsqmi(sensor_pose.translation(), directions);
}

bool OccupancyMap::save(const std::string& path) const {
  // A binary OctoMap keeps free or occupied only: each voxel goes in at its clamping bound, and
  // every 2^20 voxels the tree is pruned (in the voxels' order the subtrees behind are whole).
  octomap::OcTree tree(params_.resolution_m);
  tree.setClampingThresMin(params_.occupancy_clamp_min);
  tree.setClampingThresMax(params_.occupancy_clamp_max);
  const float occupied = grid_.getOccupancyThresLog();
  std::size_t added = 0;
  voxels_.forEach([&](const octomap::OcTreeKey& key, float log_odds) {
    tree.setNodeValue(
        key, log_odds >= occupied ? tree.getClampingThresMaxLog() : tree.getClampingThresMinLog(),
        /*lazy_eval=*/true);
    if (++added % (std::size_t{1} << 20) == 0) tree.prune();
  });
  tree.prune();
  tree.updateInnerOccupancy();
  return tree.writeBinaryConst(path);
}

void OccupancyMap::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  octomap::OcTree read(params_.resolution_m);
  read.setClampingThresMin(params_.occupancy_clamp_min);  // what read voxels are set to
  read.setClampingThresMax(params_.occupancy_clamp_max);
  if (!read.readBinary(in)) throw std::runtime_error(path + " is not a binary OctoMap");
  if (std::abs(read.getResolution() - params_.resolution_m) > 1e-9) {
    throw std::runtime_error(path + " has voxels of " + std::to_string(read.getResolution()) +
                             " m, not resolution_m " + std::to_string(params_.resolution_m));
  }
  voxels_.clear();
  const int depth = static_cast<int>(read.getTreeDepth());
  for (auto it = read.begin_leafs(), end = read.end_leafs(); it != end; ++it) {
    // A pruned leaf stands for a cube of finest voxels from its lowest key.
    const int side = 1 << (depth - static_cast<int>(it.getDepth()));
    const octomap::OcTreeKey low = it.getIndexKey();
    const float log_odds = it->getLogOdds();
    bool created = false;
    for (int x = 0; x < side; ++x) {
      for (int y = 0; y < side; ++y) {
        for (int z = 0; z < side; ++z) {
          voxels_.at(octomap::OcTreeKey(static_cast<octomap::key_type>(low[0] + x),
                                        static_cast<octomap::key_type>(low[1] + y),
                                        static_cast<octomap::key_type>(low[2] + z)),
                     created) = log_odds;
        }
      }
    }
  }
  const Box box{params_.entropyBoxMin(), params_.entropyBoxMax()};
  box_entropy_bits_ = entropyBits(box);
  box_known_voxels_ = knownVolumeM3(box) / std::pow(params_.resolution_m, 3);
}

}  // namespace ccir_mapping::core::information
