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
    : params_(validated(params)), tree_(params.resolution_m) {
  tree_.setClampingThresMin(params_.occupancy_clamp_min);
  tree_.setClampingThresMax(params_.occupancy_clamp_max);
  // validate() checked that the box lies within OctoMap's reach.
  tree_.coordToKeyChecked(toOctomap(params_.entropyBoxMin()), box_min_key_);
  tree_.coordToKeyChecked(toOctomap(params_.entropyBoxMax()), box_max_key_);
  box_entropy_bits_ = 1.0;
  for (int a = 0; a < 3; ++a) box_entropy_bits_ *= box_max_key_[a] - box_min_key_[a] + 1;
}

double OccupancyMap::boxKnownVolumeM3() const {
  return box_known_voxels_ * std::pow(params_.resolution_m, 3);
}

octomap::OcTreeNode* OccupancyMap::finestLeaf(const octomap::OcTreeKey& key) {
  // OcTreeBaseImpl::search's descent, except that a pruned leaf above the finest depth (it
  // stands for many voxels) counts as not found: updateNode must split it. It starts where the
  // last key's path parts from this one's: keys come in the tree's order, so that is mostly a
  // level or two above the leaf. Nodes are added, never moved; what deletes them (forget(), or
  // a prune that shrinks the tree) ends the path.
  const int depth = static_cast<int>(tree_.getTreeDepth());
  const std::uint64_t code = KeyBricks::morton(key);
  octomap::OcTreeNode* const root = tree_.getRoot();
  int from = 0;
  if (path_[0] == root && root && tree_.size() >= path_tree_size_) {
    const std::uint64_t differ = code ^ path_code_;
    // Key bit b picks the child at depth - 1 - b; Morton bits 3b..3b + 2 hold it.
    const int shared = differ ? depth - 1 - (63 - __builtin_clzll(differ)) / 3 : depth;
    from = std::min(shared, path_depth_);
  }
  path_[0] = root;
  path_code_ = code;
  path_depth_ = from;
  octomap::OcTreeNode* node = path_[static_cast<std::size_t>(from)];
  for (int d = from; node && d < depth; ++d) {
    const unsigned child = octomap::computeChildIdx(key, depth - 1 - d);
    if (!tree_.nodeChildExists(node, child)) {
      node = nullptr;
      break;
    }
    node = tree_.getNodeChild(node, child);
    path_[static_cast<std::size_t>(d + 1)] = node;
    path_depth_ = d + 1;
  }
  path_tree_size_ = tree_.size();
  return node;
}

octomap::OcTreeNode* OccupancyMap::newLeaf(const octomap::OcTreeKey& key) {
  if (path_[0] != tree_.getRoot() || path_code_ != KeyBricks::morton(key)) return nullptr;
  octomap::OcTreeNode* node = path_[static_cast<std::size_t>(path_depth_)];
  if (!node || !tree_.nodeHasChildren(node)) return nullptr;  // a pruned leaf, or no tree
  const int depth = static_cast<int>(tree_.getTreeDepth());
  for (int d = path_depth_; d < depth; ++d) {
    node = tree_.createNodeChild(node, octomap::computeChildIdx(key, depth - 1 - d));
    path_[static_cast<std::size_t>(d + 1)] = node;
  }
  path_depth_ = depth;
  path_tree_size_ = tree_.size();
  return node;
}

void OccupancyMap::update(const octomap::OcTreeKey& key, bool hit) {
  bool in_box = true;
  for (int a = 0; a < 3; ++a) in_box &= key[a] >= box_min_key_[a] && key[a] <= box_max_key_[a];
  // A voxel the map has at the finest depth is updated in place, as updateNode with lazy
  // evaluation would (add the log-odds, clamp; inner nodes wait): one descent instead of two.
  if (octomap::OcTreeNode* leaf = finestLeaf(key)) {
    const double h_before = in_box ? entropy_(leaf->getLogOdds()) : 0.0;
    tree_.updateNodeLogOdds(leaf, hit ? tree_.getProbHitLog() : tree_.getProbMissLog());
    if (in_box) box_entropy_bits_ += entropy_(leaf->getLogOdds()) - h_before;
    return;
  }
  if (octomap::OcTreeNode* fresh = newLeaf(key)) {
    tree_.updateNodeLogOdds(fresh, hit ? tree_.getProbHitLog() : tree_.getProbMissLog());
    if (in_box) {
      box_known_voxels_ += 1.0;
      box_entropy_bits_ += entropy_(fresh->getLogOdds()) - 1.0;
    }
    return;
  }
  if (!in_box) {  // inside a pruned leaf (updateNode splits it), or no tree yet
    tree_.updateNode(key, hit, /*lazy_eval=*/true);
    return;
  }
  const octomap::OcTreeNode* before = tree_.search(key);  // a pruned leaf, or nothing
  const double h_before = before ? entropy_(before->getLogOdds()) : 1.0;
  box_known_voxels_ += before ? 0.0 : 1.0;
  const octomap::OcTreeNode* after = tree_.updateNode(key, hit, /*lazy_eval=*/true);
  box_entropy_bits_ += entropy_(after->getLogOdds()) - h_before;
}

void OccupancyMap::forget(const octomap::OcTreeKey& key) {
  path_[0] = nullptr;  // finestLeaf's path may lose nodes
  // OcTreeBaseImpl::deleteNode deletes an inner node its last child left with the child array
  // still allocated, which OctoMap 1.9's node destructor asserts against: the path is walked
  // here, and an emptied node's array released (expandNode, then pruneNode) before it goes.
  const int depth = static_cast<int>(tree_.getTreeDepth());
  std::vector<std::pair<octomap::OcTreeNode*, unsigned>> path;
  octomap::OcTreeNode* node = tree_.getRoot();
  for (int d = 0; node && d < depth; ++d) {
    const unsigned child = octomap::computeChildIdx(key, depth - 1 - d);
    if (!tree_.nodeChildExists(node, child)) {
      if (tree_.nodeHasChildren(node) || d == 0) return;  // not in the map
      tree_.expandNode(node);                             // a pruned leaf holding the voxel
    }
    path.emplace_back(node, child);
    node = tree_.getNodeChild(node, child);
  }
  for (auto step = path.rbegin(); step != path.rend(); ++step) {
    auto [parent, child] = *step;
    tree_.deleteNodeChild(parent, child);
    if (tree_.nodeHasChildren(parent)) return;
    if (parent == tree_.getRoot()) return tree_.clear();
    tree_.expandNode(parent);
    tree_.pruneNode(parent);
  }
}

void OccupancyMap::assign(
    const std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>>& voxels) {
  for (const auto& [key, log_odds] : voxels) {
    bool in_box = true;
    for (int a = 0; a < 3; ++a) in_box &= key[a] >= box_min_key_[a] && key[a] <= box_max_key_[a];
    octomap::OcTreeNode* leaf = finestLeaf(key);
    if (in_box) {
      const octomap::OcTreeNode* before = leaf ? leaf : tree_.search(key);  // or a pruned leaf
      box_entropy_bits_ -= before ? entropy_(before->getLogOdds()) : 1.0;
      box_known_voxels_ -= before ? 1.0 : 0.0;
    }
    if (!log_odds) {
      forget(key);
      if (in_box) box_entropy_bits_ += 1.0;
      continue;
    }
    const float value =
        std::clamp(*log_odds, tree_.getClampingThresMinLog(), tree_.getClampingThresMaxLog());
    if (!leaf) leaf = newLeaf(key);
    if (leaf) {
      leaf->setLogOdds(value);
    } else {  // inside a pruned leaf (setNodeValue splits it), or no tree yet
      tree_.setNodeValue(key, value, /*lazy_eval=*/true);
    }
    if (in_box) {
      box_entropy_bits_ += entropy_(value);
      box_known_voxels_ += 1.0;
    }
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
    if (tree_.computeRayKeys(from, end, ray)) {
      for (const auto& key : ray) free_cells.insert(key);
    }
    octomap::OcTreeKey key;
    if (hit && tree_.coordToKeyChecked(end, key)) occupied_cells.insert(key);
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
  for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
    if (tree_.isNodeOccupied(*it))
      centres.push_back(pcl::PointXYZ(it.getX(), it.getY(), it.getZ()));
  }
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
  const float updated = log_odds + (hit ? tree_.getProbHitLog() : tree_.getProbMissLog());
  return std::clamp(updated, tree_.getClampingThresMinLog(), tree_.getClampingThresMaxLog());
}

double OccupancyMap::occupancy(const octomap::OcTreeKey& key) const {
  const octomap::OcTreeNode* node = tree_.search(key);
  return node ? node->getOccupancy() : 0.5;
}

double OccupancyMap::entropyDrop(const octomap::OcTreeKey& key, bool hit) const {
  const octomap::OcTreeNode* node = tree_.search(key);
  const float before = node ? node->getLogOdds() : 0.0F;
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

/// Calls f(leaf, finest voxels of the leaf inside the box) for every known leaf in the box.
template <class F>
void forLeavesInBox(const octomap::OcTree& tree, const Box& box, F&& f) {
  const double res = tree.getResolution();
  octomap::OcTreeKey min_key;
  octomap::OcTreeKey max_key;
  if (!tree.coordToKeyChecked(toOctomap(box.min), min_key) ||
      !tree.coordToKeyChecked(toOctomap(box.max), max_key)) {
    return;
  }
  Eigen::Vector3d lo;
  Eigen::Vector3d hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = tree.keyToCoord(min_key[a]) - res / 2;
    hi[a] = tree.keyToCoord(max_key[a]) + res / 2;
  }
  for (auto it = tree.begin_leafs_bbx(min_key, max_key), end = tree.end_leafs_bbx(); it != end;
       ++it) {
    // A pruned leaf stands for 8^(16 - depth) finest voxels; count those inside the box.
    const double half = it.getSize() / 2;
    const octomap::point3d c = it.getCoordinate();
    double voxels = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double overlap =
          std::min<double>(hi[a], c(a) + half) - std::max<double>(lo[a], c(a) - half);
      voxels *= std::max(0.0, std::round(overlap / res));
    }
    if (voxels > 0) f(*it, voxels);
  }
}

double boxVoxels(const octomap::OcTree& tree, const Box& box) {
  octomap::OcTreeKey min_key;
  octomap::OcTreeKey max_key;
  if (!tree.coordToKeyChecked(toOctomap(box.min), min_key) ||
      !tree.coordToKeyChecked(toOctomap(box.max), max_key)) {
    return 0.0;
  }
  double voxels = 1.0;
  for (int a = 0; a < 3; ++a) voxels *= std::max(0, max_key[a] - min_key[a] + 1);
  return voxels;
}

}  // namespace

double OccupancyMap::entropyBits(const Box& box) const {
  double known = 0.0;
  double bits = 0.0;
  forLeavesInBox(tree_, box, [&](const octomap::OcTreeNode& leaf, double voxels) {
    known += voxels;
    bits += voxels * occupancyEntropyBits(leaf.getOccupancy());
  });
  return bits + (boxVoxels(tree_, box) - known);
}

double OccupancyMap::knownVolumeM3(const Box& box) const {
  double known = 0.0;
  forLeavesInBox(tree_, box, [&](const octomap::OcTreeNode&, double voxels) { known += voxels; });
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
    if (!tree_.computeRayKeys(toOctomap(origin + unit * from), toOctomap(origin + unit * to),
                              ray)) {
      return beam;
    }
    for (const auto& key : ray) {
      const double o = occupancy(key);
      const octomap::point3d c = tree_.keyToCoord(key);
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

bool OccupancyMap::save(const std::string& path) {
  tree_.updateInnerOccupancy();
  return tree_.writeBinaryConst(path);
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
  // Inserting updates finest voxels only (finestLeaf): a pruned file is expanded.
  read.expand();
  tree_.swapContent(read);
  path_[0] = nullptr;
  const Box box{params_.entropyBoxMin(), params_.entropyBoxMax()};
  box_entropy_bits_ = entropyBits(box);
  box_known_voxels_ = knownVolumeM3(box) / std::pow(params_.resolution_m, 3);
}

}  // namespace ccir_mapping::core::information
