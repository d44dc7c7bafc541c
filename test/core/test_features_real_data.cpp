// Real VLP-16 scans (CCIR_DATA_DIR/lidar): 16line_1 and 16line_2 are the same place revisited,
// 16line_other is elsewhere. Spin-image correspondences must tell them apart.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include <pcl/io/pcd_io.h>

#include "ccir_mapping/core/features/descriptor_matcher.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"

namespace ccir_mapping::core::features {
namespace {

std::filesystem::path dataDir() {
  const char* dir = std::getenv("CCIR_DATA_DIR");
  return dir ? std::filesystem::path(dir) : std::filesystem::path(CCIR_DEFAULT_DATA_DIR);
}

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
