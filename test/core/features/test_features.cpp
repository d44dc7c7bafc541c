// ISS keypoints and spin images (algorithms.md section 2.6): layout, plane, invariances,
// keypoints on synthetic boxes, determinism, NaN safety, and descriptor matching.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include <Eigen/Geometry>

#include "ccir_mapping/core/features/descriptor_matcher.h"
#include "ccir_mapping/core/features/feature_extractor.h"

namespace ccir_mapping::core::features {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZINormal>;
constexpr int kColumns = 2 * kSpinImageWidth + 1;  // beta bins; rows are alpha bins

pcl::PointXYZINormal point(const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  pcl::PointXYZINormal q;
  q.getVector3fMap() = p;
  q.getNormalVector3fMap() = n.normalized();
  return q;
}

float bin(const SpinImage& image, int alpha, int beta_column) {
  return image[static_cast<size_t>(alpha * kColumns + beta_column)];
}

/// Points on the faces of axis-aligned boxes (corner at `min`, size `size`), `step` apart with a
/// little seeded jitter (a perfect grid makes ISS saliencies tie), normals outward.
void addBox(Cloud& cloud, const Eigen::Vector3f& min, const Eigen::Vector3f& size, float step) {
  std::mt19937 rng(static_cast<unsigned>(cloud.size()) + 1);
  std::uniform_real_distribution<float> jitter(-0.005F, 0.005F);
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = side ? 1.0F : -1.0F;
      for (float a = 0; a <= size[u] + 1e-4F; a += step) {
        for (float b = 0; b <= size[v] + 1e-4F; b += step) {
          Eigen::Vector3f p = min;
          p[axis] += side * size[axis];
          p[u] += a + jitter(rng);
          p[v] += b + jitter(rng);
          cloud.push_back(point(p, normal));
        }
      }
    }
  }
}

Cloud boxes() {
  Cloud cloud;
  addBox(cloud, {2, -1, -0.5F}, {1.0F, 2.0F, 1.5F}, 0.1F);
  addBox(cloud, {-4, 2, -0.5F}, {2.0F, 1.0F, 1.0F}, 0.1F);
  addBox(cloud, {-1, -5, -0.5F}, {1.5F, 1.5F, 2.0F}, 0.1F);
  return cloud;
}

FeatureParams denseParams() {
  FeatureParams params;
  params.voxel_m = 0.0;  // the synthetic clouds are already even
  params.drop_horizontal = preprocess::HorizontalFilter::kNone;
  params.iss_salient_radius_m = 0.4;
  params.iss_non_max_radius_m = 0.5;
  params.normal_radius_m = 0.25;
  params.spin_support_m = 1.0;
  return params;
}

TEST(SpinImages, OneNeighbourLandsInFourBilinearBins) {
  FeatureParams params;
  params.spin_support_m = 2.5;
  const FeatureExtractor extractor(params);
  const double bin_m = params.spin_support_m / kSpinImageWidth / std::sqrt(2.0);
  auto cloud = pcl::make_shared<Cloud>();
  cloud->push_back(point({0, 0, 0}, {1, 0, 0}));
  // alpha 1.5 bins from the z axis, beta 2.25 bins above the point.
  cloud->push_back(
      point({static_cast<float>(1.5 * bin_m), 0, static_cast<float>(2.25 * bin_m)}, {1, 0, 0}));
  const auto images = extractor.describe(cloud, {0}, Eigen::Vector3f::UnitZ());
  ASSERT_TRUE(images[0]);
  const SpinImage& image = *images[0];
  const int beta = kSpinImageWidth + 2;  // floor(2.25) bins above the middle column
  EXPECT_NEAR(bin(image, 1, beta), 0.5 * 0.75, 1e-5);
  EXPECT_NEAR(bin(image, 2, beta), 0.5 * 0.75, 1e-5);
  EXPECT_NEAR(bin(image, 1, beta + 1), 0.5 * 0.25, 1e-5);
  EXPECT_NEAR(bin(image, 2, beta + 1), 0.5 * 0.25, 1e-5);
  float sum = 0.0F;
  for (float v : image) sum += v;
  EXPECT_NEAR(sum, 1.0F, 1e-5);
}

TEST(SpinImages, PointsOnAPlaneFillOnlyTheMiddleColumnAroundTheNormal) {
  FeatureParams params = denseParams();
  params.spin_axis = SpinAxis::kNormal;
  const FeatureExtractor extractor(params);
  auto plane = pcl::make_shared<Cloud>();
  for (float x = -1.5F; x <= 1.5F; x += 0.05F) {
    for (float y = -1.5F; y <= 1.5F; y += 0.05F) plane->push_back(point({x, y, 2.0F}, {0, 0, 1}));
  }
  const auto images =
      extractor.describe(plane, {static_cast<int>(plane->size() / 2)}, Eigen::Vector3f::UnitZ());
  ASSERT_TRUE(images[0]);
  float middle = 0.0F;
  for (int alpha = 0; alpha <= kSpinImageWidth; ++alpha) {
    for (int column = 0; column < kColumns; ++column) {
      if (column == kSpinImageWidth) {
        middle += bin(*images[0], alpha, column);
      } else {
        ASSERT_NEAR(bin(*images[0], alpha, column), 0.0F, 1e-6) << alpha << ", " << column;
      }
    }
  }
  EXPECT_NEAR(middle, 1.0F, 1e-5);
}

/// Each image moved by `motion` vs the reference: largest bin difference and L1 distance.
std::pair<float, float> imageChange(const FeatureExtractor& extractor,
                                    const Eigen::Affine3f& motion) {
  auto scene = pcl::make_shared<Cloud>(boxes());
  auto moved = pcl::make_shared<Cloud>();
  for (const auto& p : *scene) {
    moved->push_back(
        point(motion * p.getVector3fMap(), motion.linear() * p.getNormalVector3fMap()));
  }
  const pcl::Indices at{10, 200, 777, 1500};
  const auto reference = extractor.describe(scene, at, Eigen::Vector3f::UnitZ());
  const auto after = extractor.describe(moved, at, Eigen::Vector3f::UnitZ());
  float largest = 0.0F;
  float l1 = 0.0F;
  for (size_t i = 0; i < at.size(); ++i) {
    EXPECT_TRUE(reference[i] && after[i]);
    if (!reference[i] || !after[i]) continue;
    float distance = 0.0F;
    for (int k = 0; k < kSpinImageBins; ++k) {
      const float d = std::abs((*reference[i])[k] - (*after[i])[k]);
      largest = std::max(largest, d);
      distance += d;
    }
    l1 = std::max(l1, distance);
  }
  return {largest, l1};
}

TEST(SpinImages, InvariantToTranslation) {
  Eigen::Affine3f shift = Eigen::Affine3f::Identity();
  shift.translate(Eigen::Vector3f(10.3F, -5.7F, 3.1F));
  EXPECT_LT(imageChange(FeatureExtractor(denseParams()), shift).first, 1e-5F);
}

TEST(SpinImages, InvariantToRotationAboutUpUpToResampling) {
  // A support point near the cylinder's border may fall in or out after rounding: the images
  // stay equal up to such resampling.
  Eigen::Affine3f turn = Eigen::Affine3f::Identity();
  turn.rotate(Eigen::AngleAxisf(0.6F, Eigen::Vector3f::UnitZ()));
  EXPECT_LT(imageChange(FeatureExtractor(denseParams()), turn).second, 0.03F);
}

TEST(SpinImages, FlippingTheAxisMirrorsBeta) {
  FeatureParams params = denseParams();
  params.spin_axis = SpinAxis::kNormal;
  const FeatureExtractor extractor(params);
  auto scene = pcl::make_shared<Cloud>(boxes());
  auto flipped = pcl::make_shared<Cloud>(*scene);
  for (auto& p : *flipped) p.getNormalVector3fMap() *= -1.0F;
  const pcl::Indices at{100, 900};
  const auto a = extractor.describe(scene, at, Eigen::Vector3f::UnitZ());
  const auto b = extractor.describe(flipped, at, Eigen::Vector3f::UnitZ());
  for (size_t i = 0; i < at.size(); ++i) {
    ASSERT_TRUE(a[i] && b[i]);
    for (int alpha = 0; alpha <= kSpinImageWidth; ++alpha) {
      for (int column = 0; column < kColumns; ++column) {
        ASSERT_NEAR(bin(*a[i], alpha, column), bin(*b[i], alpha, kColumns - 1 - column), 1e-4);
      }
    }
  }
}

/// Distance from p to the nearest edge of the axis-aligned box [min, min + size].
float distanceToEdges(const Eigen::Vector3f& p, const Eigen::Vector3f& min,
                      const Eigen::Vector3f& size) {
  float best = 1e9F;
  for (int axis = 0; axis < 3; ++axis) {  // edges parallel to `axis`
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    for (int su = 0; su < 2; ++su) {
      for (int sv = 0; sv < 2; ++sv) {
        const float along = std::clamp(p[axis], min[axis], min[axis] + size[axis]);
        Eigen::Vector3f q;
        q[axis] = along;
        q[u] = min[u] + su * size[u];
        q[v] = min[v] + sv * size[v];
        best = std::min(best, (p - q).norm());
      }
    }
  }
  return best;
}

TEST(Keypoints, OnBoxEdgesNeverOnFacesSpacedAndDeterministic) {
  const FeatureParams params = denseParams();
  const FeatureExtractor extractor(params);
  const Cloud scene = boxes();
  ExtractionStats stats;
  const LocalFeatures features = extractor.extract(scene, Eigen::Vector3f::UnitZ(), &stats);
  ASSERT_GT(features.size(), 10U);
  EXPECT_EQ(stats.keypoints, stats.descriptors + stats.sparse + stats.degenerate);
  const std::vector<std::pair<Eigen::Vector3f, Eigen::Vector3f>> box_list{
      {{2, -1, -0.5F}, {1.0F, 2.0F, 1.5F}},
      {{-4, 2, -0.5F}, {2.0F, 1.0F, 1.0F}},
      {{-1, -5, -0.5F}, {1.5F, 1.5F, 2.0F}}};
  for (const auto& k : features.keypoints) {
    float nearest = 1e9F;
    for (const auto& [min, size] : box_list)
      nearest = std::min(nearest, distanceToEdges(k, min, size));
    EXPECT_LE(nearest, params.iss_non_max_radius_m) << k.transpose() << " is inside a face";
  }
  for (size_t i = 0; i < features.size(); ++i) {
    for (size_t j = i + 1; j < features.size(); ++j) {
      EXPECT_GT((features.keypoints[i] - features.keypoints[j]).norm(),
                params.iss_non_max_radius_m - 1e-3)
          << "keypoints " << i << " and " << j << " survived each other's suppression";
    }
  }
  const LocalFeatures again = extractor.extract(scene, Eigen::Vector3f::UnitZ());
  ASSERT_EQ(again.size(), features.size());
  for (size_t i = 0; i < features.size(); ++i) {
    EXPECT_EQ(again.keypoints[i], features.keypoints[i]);
    EXPECT_EQ(again.descriptors[i], features.descriptors[i]);
  }
}

TEST(Keypoints, NaNsIsolatedPointsAndEmptyCloudsAreSafe) {
  const FeatureExtractor extractor(denseParams());
  Cloud scene = boxes();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 50; ++i) {
    scene.push_back(point({nan, 0, 0}, {1, 0, 0}));
    scene.push_back(point({30.0F + i, 30.0F, 0}, {1, 0, 0}));  // isolated
    pcl::PointXYZINormal bad_normal = point({1, 1, 1}, {1, 0, 0});
    bad_normal.normal_x = nan;
    scene.push_back(bad_normal);
  }
  LocalFeatures features;
  ASSERT_NO_THROW(features = extractor.extract(scene, Eigen::Vector3f::UnitZ()));
  EXPECT_GT(features.size(), 5U);
  for (const auto& d : features.descriptors) {
    for (float v : d) ASSERT_TRUE(std::isfinite(v));
  }
  EXPECT_EQ(extractor.extract(Cloud(), Eigen::Vector3f::UnitZ()).size(), 0U);
  Cloud few;
  few.push_back(point({1, 0, 0}, {1, 0, 0}));
  EXPECT_EQ(extractor.extract(few, Eigen::Vector3f::UnitZ()).size(), 0U);
}

TEST(FeatureParams, InvalidValuesNameTheParameter) {
  FeatureParams params;
  params.spin_support_m = 0.0;
  ASSERT_EQ(params.validate().size(), 1U);
  EXPECT_EQ(params.validate().front().rfind("spin_support_m", 0), 0U);
  EXPECT_THROW(FeatureExtractor{params}, std::invalid_argument);
  EXPECT_EQ(parseSpinAxis("z_up"), SpinAxis::kZUp);
  EXPECT_FALSE(parseSpinAxis("sideways"));
}

TEST(DescriptorMatching, MutualNearestWithRatioTest) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  std::vector<SpinImage> a(40);
  for (auto& d : a) {
    for (float& v : d) v = u(rng);
  }
  // b: the first 20 of a, slightly perturbed and shuffled, plus 20 unrelated.
  std::vector<SpinImage> b;
  std::vector<int> source;
  for (int i = 19; i >= 0; --i) {
    SpinImage d = a[static_cast<size_t>(i)];
    for (float& v : d) v += 0.01F * u(rng);
    b.push_back(d);
    source.push_back(i);
  }
  for (int i = 0; i < 20; ++i) {
    SpinImage d;
    for (float& v : d) v = u(rng);
    b.push_back(d);
    source.push_back(-1);
  }
  const auto matches = mutualMatches(a, b, 0.8);
  ASSERT_EQ(matches.size(), 20U);
  for (const auto& [i, j] : matches) EXPECT_EQ(source[static_cast<size_t>(j)], i);
  EXPECT_TRUE(mutualMatches(a, {}, 0.8).empty());
  EXPECT_TRUE(mutualMatches({a[0]}, {a[0]}, 0.8).empty());  // no second neighbour: no ratio
}

TEST(DescriptorMatcher, NearestMatchesKeepRepeatedStructureForRansac) {
  // Three identical descriptors (the same pillar corner seen thrice) fail any ratio test; the k
  // nearest keep every pairing among them, each pair once.
  SpinImage corner;
  corner.fill(0.5F);
  SpinImage other;
  other.fill(0.0F);
  const std::vector<SpinImage> a = {corner, corner, other};
  const std::vector<SpinImage> b = {corner, other, corner};
  EXPECT_TRUE(mutualMatches(a, b, 0.8).size() == 1U);  // only other-other survives the ratio
  const auto matches = nearestMatches(a, b, 2);
  const std::set<std::pair<int, int>> unique(matches.begin(), matches.end());
  EXPECT_EQ(unique.size(), matches.size());
  for (const auto& pair : {std::pair{0, 0}, {0, 2}, {1, 0}, {1, 2}, {2, 1}}) {
    EXPECT_EQ(unique.count(pair), 1U) << pair.first << "-" << pair.second;
  }
  EXPECT_TRUE(nearestMatches(a, {}, 3).empty());
}

}  // namespace
}  // namespace ccir_mapping::core::features
