// A pcl::search::KdTree whose single-point queries run on the calling thread alone (queries
// from several threads at once are safe, as with PCL's).
//
// PCL's KdTreeFLANN is compiled with OpenMP and wraps every single-point query in a parallel
// region of one thread; closing that region's barrier is a futex system call. GICP, the
// verifier's overlap test and normal, keypoint and spin-image estimation make ~10^5 such
// queries per keyframe, and on the virtual machines we replay on the calls were a fifth of the
// Matcher's CPU as system time. This tree builds the same index (FLANN's single kd-tree, 15
// points a leaf, exact search over the finite points, xyz as PCL's default representation of
// these point types) and answers the same neighbours; it is written by hand because neither PCL
// nor FLANN offers a single query outside OpenMP. Our code is built without OpenMP, so FLANN's
// templates instantiated here have no parallel region. It always searches x, y, z: a point
// representation set on it is not used (none of our callers sets one).
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/util/result_set.h>
#include <pcl/point_cloud.h>
#include <pcl/search/kdtree.h>

namespace ccir_mapping::core::common {

template <class PointT>
class SerialKdTree : public pcl::search::KdTree<PointT> {
 public:
  using Base = pcl::search::KdTree<PointT>;
  using Ptr = std::shared_ptr<SerialKdTree<PointT>>;
  using Base::nearestKSearch;
  using Base::radiusSearch;
  using typename Base::IndicesConstPtr;
  using typename Base::PointCloudConstPtr;

  /// `sorted`: radius results by distance (k-nearest results always are).
  explicit SerialKdTree(bool sorted = true) : Base(sorted) {}

  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override {
    this->input_ = cloud;
    this->indices_ = indices;
    index_.reset();
    coordinates_.clear();
    ids_.clear();
    if (!cloud) return;
    const auto add = [&](pcl::index_t i) {
      const PointT& p = (*cloud)[i];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return;
      coordinates_.insert(coordinates_.end(), {p.x, p.y, p.z});
      ids_.push_back(i);
    };
    if (indices) {
      for (const pcl::index_t i : *indices) add(i);
    } else {
      for (pcl::index_t i = 0; i < static_cast<pcl::index_t>(cloud->size()); ++i) add(i);
    }
    if (ids_.empty()) return;
    index_ = std::make_unique<Index>(flann::Matrix<float>(coordinates_.data(), ids_.size(), 3),
                                     flann::KDTreeSingleIndexParams(15));
    index_->buildIndex();
  }

  int nearestKSearch(const PointT& point, int k, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override {
    k = std::clamp<int>(k, 0, static_cast<int>(ids_.size()));
    k_indices.resize(k);
    k_sqr_distances.resize(k);
    if (k == 0) return 0;
    flann::KNNSimpleResultSet<float> result(static_cast<std::size_t>(k));
    find(result, point);
    std::vector<std::size_t> found(k);
    result.copy(found.data(), k_sqr_distances.data(), k, /*sorted=*/true);
    for (int i = 0; i < k; ++i) k_indices[i] = ids_[found[i]];
    return k;
  }

  /// max_nn 0 (or more than the cloud holds): every point within radius.
  int radiusSearch(const PointT& point, double radius, pcl::Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
    k_indices.clear();
    k_sqr_distances.clear();
    if (!index_) return 0;
    const auto radius2 = static_cast<float>(radius * radius);
    std::size_t n = 0;
    if (max_nn == 0 || max_nn >= ids_.size()) {
      flann::RadiusResultSet<float> result(radius2);
      find(result, point);
      n = collect(result, k_indices, k_sqr_distances);
    } else {
      flann::KNNRadiusResultSet<float> result(radius2, max_nn);
      find(result, point);
      n = collect(result, k_indices, k_sqr_distances);
    }
    return static_cast<int>(n);
  }

 private:
  using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

  void find(flann::ResultSet<float>& result, const PointT& point) const {
    if (!index_) return;
    const float query[3] = {point.x, point.y, point.z};
    index_->findNeighbors(result, query, flann::SearchParams(-1, 0.0F, this->sorted_results_));
  }

  template <class ResultSet>
  std::size_t collect(ResultSet& result, pcl::Indices& k_indices,
                      std::vector<float>& k_sqr_distances) const {
    const std::size_t n = result.size();
    k_indices.resize(n);
    k_sqr_distances.resize(n);
    if (n == 0) return 0;
    std::vector<std::size_t> found(n);
    result.copy(found.data(), k_sqr_distances.data(), n, this->sorted_results_);
    for (std::size_t i = 0; i < n; ++i) k_indices[i] = ids_[found[i]];
    return n;
  }

  std::vector<float> coordinates_;
  std::vector<pcl::index_t> ids_;
  std::unique_ptr<Index> index_;
};

}  // namespace ccir_mapping::core::common
