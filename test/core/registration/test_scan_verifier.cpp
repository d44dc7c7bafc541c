// The geometric verification of two scans (RANSAC over descriptor matches, then GICP): what is
// rejected and why, free-space violations, mixture tolerances, compacted scans.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "ccir_mapping/core/registration/scan_verifier.h"

namespace ccir_mapping::core::registration {
namespace {

TEST(ScanVerifier, DescriptorsWithoutGeometricConsensusAreRejectedEvenOnIdenticalClouds) {
  // The two clouds are the same place, so GICP from identity would fit perfectly; but the
  // descriptors pair keypoints at random positions, so no rigid transform explains them.
  // (PCL's CorrespondenceRejectorSampleConsensus falls back to identity when RANSAC fails.)
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-10.0F, 10.0F);
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  for (int i = 0; i < 2000; ++i) {
    pcl::PointXYZINormal p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = 0.1F * u(rng);
    // Half floor, half walls (the overlap test looks at walls only).
    (i % 2 ? p.normal_x : p.normal_z) = 1.0F;
    cloud.push_back(p);
  }
  features::LocalFeatures from;
  features::LocalFeatures to;
  for (int i = 0; i < 40; ++i) {
    features::SpinImage d;
    for (float& v : d) v = 0.5F + 0.05F * u(rng);
    from.keypoints.emplace_back(u(rng), u(rng), u(rng));
    from.descriptors.push_back(d);
    to.keypoints.emplace_back(u(rng), u(rng), u(rng));
    to.descriptors.push_back(d);
  }
  const ScanVerifier verifier{VerificationParams{}};
  const Verification v = verifier.verify(cloud, from, cloud, to);
  EXPECT_FALSE(v.accepted);
  EXPECT_LT(v.inliers, VerificationParams{}.min_inliers) << v.reason;
  EXPECT_NE(v.reason.find("agree"), std::string::npos) << v.reason;

  // The same keypoints on both sides (a rigid identity) verify.
  const Verification same = verifier.verify(cloud, from, cloud, from);
  EXPECT_TRUE(same.accepted) << same.reason;
  EXPECT_LT(same.relative.translation().norm(), 0.05);
}

/// Points every `step` on the walls of a square room around the sensor (half-width `half_m`,
/// from 0.5 m below to 3.5 m above it), normals inward.
pcl::PointCloud<pcl::PointXYZINormal> room(float half_m, float step) {
  pcl::PointCloud<pcl::PointXYZINormal> cloud;
  for (int wall = 0; wall < 4; ++wall) {
    const float sign = wall < 2 ? 1.0F : -1.0F;
    const int axis = wall % 2;
    for (float a = -half_m; a <= half_m; a += step) {
      for (float z = -0.5F; z <= 3.5F; z += step) {
        pcl::PointXYZINormal p;
        (axis ? p.y : p.x) = sign * half_m;
        (axis ? p.x : p.y) = a;
        p.z = z;
        (axis ? p.normal_y : p.normal_x) = -sign;
        cloud.push_back(p);
      }
    }
  }
  return cloud;
}

/// 20 keypoints in the room, with descriptors: the same on both sides of a pair, RANSAC finds
/// the identity and the room's geometry decides.
features::LocalFeatures roomKeypoints() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-6.0F, 6.0F);
  features::LocalFeatures features;
  for (int i = 0; i < 20; ++i) {
    features::SpinImage d;
    for (float& v : d) v = 0.5F + 0.05F * u(rng);
    features.keypoints.emplace_back(u(rng), u(rng), u(rng) / 4);
    features.descriptors.push_back(d);
  }
  return features;
}

TEST(ScanVerifier, SurfaceWhereTheOtherScanSawFreeSpaceIsRejected) {
  // The same room, but one scan also sees a pillar face 4 m ahead that the other looked past:
  // the walls still overlap almost entirely, the pillar lies in the other's free space.
  const auto empty = room(8.0F, 0.1F);
  pcl::PointCloud<pcl::PointXYZINormal> with_pillar;
  for (const auto& p : empty) {
    if (p.x < 7.9F || std::abs(p.y) > 2.0F) with_pillar.push_back(p);  // the rest it hides
  }
  for (float y = -1.0F; y <= 1.0F; y += 0.1F) {
    for (float z = -0.5F; z <= 3.5F; z += 0.1F) {
      pcl::PointXYZINormal p;
      p.x = 4.0F;
      p.y = y;
      p.z = z;
      p.normal_x = -1.0F;
      with_pillar.push_back(p);
    }
  }
  const features::LocalFeatures features = roomKeypoints();
  const ScanVerifier verifier{VerificationParams{}};
  const Verification same = verifier.verify(empty, features, empty, features);
  EXPECT_TRUE(same.accepted) << same.reason;
  EXPECT_EQ(same.free_space_violation, 0.0);

  for (const auto& v : {verifier.verify(empty, features, with_pillar, features),
                        verifier.verify(with_pillar, features, empty, features)}) {
    EXPECT_FALSE(v.accepted);
    EXPECT_GT(v.overlap, 0.9) << "the overlap test alone would accept";
    EXPECT_GT(v.free_space_violation, VerificationParams{}.max_free_space_violation);
    EXPECT_NE(v.reason.find("free-space"), std::string::npos) << v.reason;
  }
}

TEST(ScanVerifier, AScanDrawnFromAMixtureIsJudgedAtTheMixtureTolerances) {
  // The same room, its second scan's points between the first's and 0.12 m off the walls on
  // either side (as points drawn from flat Gaussians lie): none within 0.1 m of the first's.
  const auto measured = room(8.0F, 0.1F);
  pcl::PointCloud<pcl::PointXYZINormal> drawn;
  for (const auto& p : room(8.0F, 0.1F)) {
    auto q = p;
    const Eigen::Vector3f normal = p.getNormalVector3fMap();
    const Eigen::Vector3f along = normal.cross(Eigen::Vector3f::UnitZ());
    q.getVector3fMap() +=
        0.05F * (along + Eigen::Vector3f::UnitZ()) + (drawn.size() % 2 ? 0.12F : -0.12F) * normal;
    drawn.push_back(q);
  }
  const features::LocalFeatures features = roomKeypoints();
  const ScanVerifier verifier{VerificationParams{}};
  const Verification as_measured =
      verifier.verify(verifier.prepare(measured, features), verifier.prepare(drawn, features));
  EXPECT_FALSE(as_measured.accepted);
  EXPECT_NE(as_measured.reason.find("wall overlap"), std::string::npos) << as_measured.reason;
  const Verification as_drawn = verifier.verify(verifier.prepare(measured, features),
                                                verifier.prepare(drawn, features, true));
  EXPECT_TRUE(as_drawn.accepted) << as_drawn.reason;
}

TEST(ScanVerifier, ACloudWithNothingToAlignIsRejectedNotCrashed) {
  // Features that agree, but no point within gicp_max_range_m (40 m) in one cloud.
  const auto near = room(8.0F, 0.1F);
  pcl::PointCloud<pcl::PointXYZINormal> far;
  for (auto p : near) {
    p.x += 100.0F;
    far.push_back(p);
  }
  const features::LocalFeatures features = roomKeypoints();
  const ScanVerifier verifier{VerificationParams{}};
  for (const auto& v :
       {verifier.verify(near, features, far, features),
        verifier.verify(far, features, near, features),
        verifier.verify(pcl::PointCloud<pcl::PointXYZINormal>(), features, near, features)}) {
    EXPECT_FALSE(v.accepted);
    EXPECT_NE(v.reason.find("too few to align"), std::string::npos) << v.reason;
  }
}

TEST(ScanVerifier, ACompactedScanKeepsItsCovariancesAndCompletesToTheSame) {
  const ScanVerifier verifier{VerificationParams{}};
  PreparedScan scan = verifier.prepare(room(8.0F, 0.1F), features::LocalFeatures{});
  ASSERT_TRUE(ScanVerifier::isComplete(scan));
  ASSERT_GT(scan.covariances->size(), 100U);
  const PreparedScan::Covariances before = *scan.covariances;
  const auto packed = scan.packed_covariances;
  ScanVerifier::compact(scan);
  EXPECT_FALSE(ScanVerifier::isComplete(scan));
  EXPECT_EQ(scan.covariances, nullptr);
  EXPECT_EQ(scan.packed_covariances, packed);  // kept: completing again estimates nothing
  verifier.complete(scan);
  ASSERT_EQ(scan.covariances->size(), before.size());
  for (std::size_t i = 0; i < before.size(); ++i) {
    ASSERT_EQ((*scan.covariances)[i], before[i]) << "point " << i;
    ASSERT_EQ(before[i], before[i].transpose());
  }
}

TEST(ScanVerifier, InvalidParametersAreNamed) {
  VerificationParams params;
  params.match_neighbors = 0;
  try {
    ScanVerifier verifier(params);
    FAIL() << "accepted match_neighbors = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("match_neighbors"), std::string::npos);
  }
  params = VerificationParams{};
  params.gicp_source_step = 0;
  EXPECT_THROW(ScanVerifier{params}, std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::registration
