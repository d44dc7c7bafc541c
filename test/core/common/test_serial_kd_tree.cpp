#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <pcl/search/kdtree.h>

#include "ccir_mapping/core/common/serial_kd_tree.h"

namespace ccir_mapping::core::common {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZI>;

/// A flat tunnel of drawn points, every 50th one NaN (PCL's tree leaves those out).
Cloud::Ptr drawnCloud(int points, unsigned seed) {
  auto cloud = std::make_shared<Cloud>();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> along(-20.0F, 20.0F);
  std::uniform_real_distribution<float> across(-2.0F, 2.0F);
  for (int i = 0; i < points; ++i) {
    pcl::PointXYZI p;
    p.x = along(rng);
    p.y = across(rng);
    p.z = i % 50 == 7 ? std::numeric_limits<float>::quiet_NaN() : across(rng);
    p.intensity = static_cast<float>(i);  // not part of the search
    cloud->push_back(p);
  }
  return cloud;
}

/// Same neighbours as PCL's KdTreeFLANN, in the same order, for k-nearest and radius queries,
/// sorted or not, bounded or not, on the whole cloud and on a subset of its indices.
TEST(SerialKdTree, AnswersAsPclsTree) {
  const Cloud::Ptr cloud = drawnCloud(3000, 5);
  const Cloud::Ptr queries = drawnCloud(200, 6);
  auto subset = std::make_shared<pcl::Indices>();
  for (int i = 0; i < 3000; i += 3) subset->push_back(i);
  for (const bool sorted : {true, false}) {
    for (const bool use_subset : {false, true}) {
      pcl::search::KdTree<pcl::PointXYZI> reference(sorted);
      SerialKdTree<pcl::PointXYZI> serial(sorted);
      reference.setInputCloud(cloud, use_subset ? subset : nullptr);
      serial.setInputCloud(cloud, use_subset ? subset : nullptr);
      EXPECT_EQ(serial.getInputCloud(), cloud);
      for (const auto& q : *queries) {
        if (!std::isfinite(q.z)) continue;
        pcl::Indices expected;
        pcl::Indices actual;
        std::vector<float> expected_d;
        std::vector<float> actual_d;
        for (const int k : {1, 7, 20}) {
          ASSERT_EQ(serial.nearestKSearch(q, k, actual, actual_d),
                    reference.nearestKSearch(q, k, expected, expected_d));
          EXPECT_EQ(actual, expected);
          EXPECT_EQ(actual_d, expected_d);
        }
        for (const unsigned max_nn : {0U, 5U}) {
          const int n = serial.radiusSearch(q, 1.0, actual, actual_d, max_nn);
          ASSERT_EQ(n, reference.radiusSearch(q, 1.0, expected, expected_d, max_nn));
          if (!sorted || max_nn) {  // the same set, in an order neither promises
            std::sort(actual.begin(), actual.end());
            std::sort(expected.begin(), expected.end());
            std::sort(actual_d.begin(), actual_d.end());
            std::sort(expected_d.begin(), expected_d.end());
          }
          EXPECT_EQ(actual, expected);
          EXPECT_EQ(actual_d, expected_d);
        }
      }
    }
  }
}

TEST(SerialKdTree, ReturnsNothingFromAnEmptyOrTinyCloud) {
  SerialKdTree<pcl::PointXYZI> tree;
  pcl::Indices indices{42};
  std::vector<float> distances{1.0F};
  pcl::PointXYZI q;
  q.x = q.y = q.z = 0.0F;
  tree.setInputCloud(std::make_shared<Cloud>());
  EXPECT_EQ(tree.nearestKSearch(q, 3, indices, distances), 0);
  EXPECT_TRUE(indices.empty());
  EXPECT_EQ(tree.radiusSearch(q, 5.0, indices, distances), 0);
  EXPECT_TRUE(distances.empty());

  const Cloud::Ptr two = drawnCloud(2, 9);
  tree.setInputCloud(two);
  EXPECT_EQ(tree.nearestKSearch(q, 10, indices, distances), 2);  // k beyond the cloud: all
  EXPECT_EQ(indices.size(), 2U);
  EXPECT_LE(distances[0], distances[1]);
}

}  // namespace
}  // namespace ccir_mapping::core::common
