// Real VLP-16 scans (CCIR_DATA_DIR/lidar): 16line_1 and 16line_2 are the same place revisited,
// 16line_other is elsewhere. Spin-image correspondences must tell them apart, and verification
// accept the revisit and reject the other place.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include <pcl/io/pcd_io.h>

#include "ccir_mapping/core/features/descriptor_matcher.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/core/registration/scan_verifier.h"

namespace ccir_mapping::core::features {

std::filesystem::path dataDir() {
  const char* dir = std::getenv("CCIR_DATA_DIR");
  return dir ? std::filesystem::path(dir) : std::filesystem::path(CCIR_DEFAULT_DATA_DIR);
}

namespace {

LocalFeatures featuresOf(const std::string& name, const FeatureParams& params) {
  pcl::PointCloud<pcl::PointXYZI> scan;
  const auto path = dataDir() / "lidar" / name;
  EXPECT_EQ(pcl::io::loadPCDFile(path.string(), scan), 0) << path;
  const preprocess::ScanPreprocessor preprocessor{preprocess::PreprocessorParams{}};
  const auto keyframe = preprocessor.process(scan, Eigen::Vector3f::UnitZ());
  const FeatureExtractor extractor(params);
  ExtractionStats stats;
  LocalFeatures features = extractor.extract(*keyframe, Eigen::Vector3f::UnitZ(), &stats);
  std::printf("%s: %zu points -> %zu keypoints -> %zu descriptors\n", name.c_str(),
              keyframe->size(), stats.keypoints, stats.descriptors);
  return features;
}

class RealScans : public ::testing::TestWithParam<preprocess::HorizontalFilter> {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(dataDir() / "lidar" / "16line_1.pcd")) {
      GTEST_SKIP() << "SKIPPED: real scans not found under " << dataDir()
                   << "/lidar (set CCIR_DATA_DIR)";
    }
  }
};

TEST_P(RealScans, RevisitHasClearlyMoreCorrespondencesThanOtherPlace) {
  FeatureParams params;
  params.drop_horizontal = GetParam();
  const LocalFeatures first = featuresOf("16line_1.pcd", params);
  const LocalFeatures second = featuresOf("16line_2.pcd", params);
  const LocalFeatures other = featuresOf("16line_other.pcd", params);
  const size_t revisit = mutualMatches(first.descriptors, second.descriptors, 0.8).size();
  const size_t first_other = mutualMatches(first.descriptors, other.descriptors, 0.8).size();
  const size_t second_other = mutualMatches(second.descriptors, other.descriptors, 0.8).size();
  std::printf("mutual matches: revisit %zu, 1-other %zu, 2-other %zu\n", revisit, first_other,
              second_other);
  EXPECT_GE(revisit, 2 * std::max(first_other, second_other));
}

INSTANTIATE_TEST_SUITE_P(Features, RealScans,
                         ::testing::Values(preprocess::HorizontalFilter::kNone,
                                           preprocess::HorizontalFilter::kGround,
                                           preprocess::HorizontalFilter::kBoth));

}  // namespace
}  // namespace ccir_mapping::core::features

namespace ccir_mapping::core::registration {
namespace {

TEST(RealScans, RevisitVerifiesAndOtherPlaceIsRejected) {
  const auto root = features::dataDir() / "lidar";
  if (!std::filesystem::exists(root / "16line_1.pcd")) {
    GTEST_SKIP() << "SKIPPED: real scans not found under " << root << " (set CCIR_DATA_DIR)";
  }
  // Outdoors the thesis's tunnel filter ("both") leaves few keypoints: keep the ceiling side.
  features::FeatureParams feature_params;
  feature_params.drop_horizontal = preprocess::HorizontalFilter::kGround;
  const preprocess::ScanPreprocessor preprocessor{preprocess::PreprocessorParams{}};
  const features::FeatureExtractor extractor(feature_params);
  struct Scan {
    preprocess::ScanPreprocessor::OutputCloud::Ptr cloud;
    features::LocalFeatures features;
  };
  auto load = [&](const char* name) {
    pcl::PointCloud<pcl::PointXYZI> raw;
    EXPECT_EQ(pcl::io::loadPCDFile((root / name).string(), raw), 0);
    Scan scan;
    scan.cloud = preprocessor.process(raw, Eigen::Vector3f::UnitZ());
    scan.features = extractor.extract(*scan.cloud, Eigen::Vector3f::UnitZ());
    return scan;
  };
  const Scan first = load("16line_1.pcd");
  const Scan second = load("16line_2.pcd");
  const Scan other = load("16line_other.pcd");
  // An outdoor scene changes more between visits than a mine's rock walls: the outdoor setting
  // (0.8 of the walls within 0.3 m, this revisit has 0.83; up to a tenth of them where the
  // other scan saw free space) instead of the mine's tight one.
  VerificationParams outdoor;
  outdoor.min_overlap = 0.8;
  outdoor.overlap_distance_m = 0.3;
  outdoor.max_free_space_violation = 0.1;
  const ScanVerifier verifier{outdoor};

  const Verification revisit =
      verifier.verify(*first.cloud, first.features, *second.cloud, second.features);
  std::printf(
      "revisit: %d matches, %d inliers, fitness %.3f, overlap %.3f, free space %.3f, yaw %.1f deg, "
      "shift %.2f m\n",
      revisit.matches, revisit.inliers, revisit.fitness_m2, revisit.overlap,
      revisit.free_space_violation,
      std::atan2(revisit.relative(1, 0), revisit.relative(0, 0)) * 180 / M_PI,
      revisit.relative.translation().norm());
  ASSERT_TRUE(revisit.accepted) << revisit.reason;
  const double yaw_deg = std::atan2(revisit.relative(1, 0), revisit.relative(0, 0)) * 180 / M_PI;
  EXPECT_NEAR(std::abs(yaw_deg), 11.0, 3.0);
  EXPECT_LT(revisit.relative.translation().norm(), 1.0);
  {  // GICP moving every point of the candidate instead of every gicp_source_step-th: the
     // same alignment, to a few centimetres.
    VerificationParams every_point = outdoor;
    every_point.gicp_source_step = 1;
    const Verification full =
        ScanVerifier(every_point)
            .verify(*first.cloud, first.features, *second.cloud, second.features);
    ASSERT_TRUE(full.accepted) << full.reason;
    const Pose3 difference = full.relative.inverse() * revisit.relative;
    EXPECT_LT(difference.translation().norm(), 0.05);
    EXPECT_LT(Eigen::AngleAxisd(difference.linear()).angle(), 0.01);
  }
  for (const Scan* scan : {&first, &second}) {
    const Verification wrong =
        verifier.verify(*scan->cloud, scan->features, *other.cloud, other.features);
    std::printf("other place: %d matches, %d inliers, fitness %.3f: %s\n", wrong.matches,
                wrong.inliers, wrong.fitness_m2, wrong.reason.c_str());
    EXPECT_FALSE(wrong.accepted);
    // Even when few matches are allowed, the geometry rejects it.
    VerificationParams lenient = outdoor;
    lenient.min_inliers = 3;
    const Verification forced =
        ScanVerifier(lenient).verify(*scan->cloud, scan->features, *other.cloud, other.features);
    std::printf("  lenient: %d inliers, fitness %.3f: %s\n", forced.inliers, forced.fitness_m2,
                forced.reason.c_str());
    EXPECT_FALSE(forced.accepted);
  }
}

}  // namespace
}  // namespace ccir_mapping::core::registration
