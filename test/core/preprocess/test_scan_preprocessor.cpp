// Scan preprocessing: range crop, voxel grid (also beyond pcl::VoxelGrid's index range),
// normals facing the sensor, the degenerate-normal filter, the 2D slice, bad input; and the
// real VLP-16 scan.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <set>
#include <tuple>

#include <pcl/io/pcd_io.h>
#include <Eigen/Geometry>

#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"

namespace ccir_mapping::core::preprocess {
namespace {

using Input = ScanPreprocessor::InputCloud;

pcl::PointXYZI xyzi(float x, float y, float z, float intensity = 10.0F) {
  pcl::PointXYZI p;
  p.x = x;
  p.y = y;
  p.z = z;
  p.intensity = intensity;
  return p;
}

/// A box room around the sensor: floor at z = -1, ceiling at z = 2, walls at x = +-5 and
/// y = +-4, sampled every 0.05 m.
Input room() {
  Input cloud;
  const float s = 0.05F;
  for (float x = -5; x <= 5 + 1e-4F; x += s) {
    for (float y = -4; y <= 4 + 1e-4F; y += s) {
      cloud.push_back(xyzi(x, y, -1));
      cloud.push_back(xyzi(x, y, 2));
    }
  }
  for (float z = -1; z <= 2 + 1e-4F; z += s) {
    for (float y = -4; y <= 4 + 1e-4F; y += s) {
      cloud.push_back(xyzi(5, y, z));
      cloud.push_back(xyzi(-5, y, z));
    }
    for (float x = -5; x <= 5 + 1e-4F; x += s) {
      cloud.push_back(xyzi(x, 4, z));
      cloud.push_back(xyzi(x, -4, z));
    }
  }
  return cloud;
}

TEST(ScanPreprocessor, CropsRangeAndDropsNoReturns) {
  Input scan;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  scan.push_back(xyzi(0.2F, 0, 0));    // too near
  scan.push_back(xyzi(150.0F, 0, 0));  // too far
  scan.push_back(xyzi(0, 0, 0));       // the driver's "no return"
  scan.push_back(xyzi(nan, 1, 1));
  scan.push_back(xyzi(1, std::numeric_limits<float>::infinity(), 1));
  for (int i = 0; i < 20; ++i) scan.push_back(xyzi(5, -0.5F + 0.05F * i, 0));  // a wall strip
  PreprocessStats stats;
  const auto out =
      ScanPreprocessor(PreprocessorParams{}).process(scan, Eigen::Vector3f::UnitZ(), &stats);
  EXPECT_EQ(stats.points_in, 25U);
  EXPECT_EQ(stats.out_of_range, 2U);
  EXPECT_EQ(stats.not_finite, 3U);
  EXPECT_EQ(stats.points_out + stats.without_normal, stats.voxels);
  for (const auto& p : *out) {
    ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.normal_x));
    ASSERT_NEAR(p.getVector3fMap().norm(), 5.0F, 0.6F);
  }
}

TEST(ScanPreprocessor, VoxelGridKeepsOnePointPerVoxelAndUnitNormalsFacingTheSensor) {
  PreprocessorParams params;
  params.voxel_leaf_m = 0.2;
  PreprocessStats stats;
  const Input scan = room();
  const auto out = ScanPreprocessor(params).process(scan, Eigen::Vector3f::UnitZ(), &stats);
  EXPECT_LT(stats.voxels, scan.size() / 10);
  std::set<std::tuple<int, int, int>> voxels;
  for (const auto& p : *out) {
    voxels.emplace(static_cast<int>(std::floor(p.x / 0.2F)),
                   static_cast<int>(std::floor(p.y / 0.2F)),
                   static_cast<int>(std::floor(p.z / 0.2F)));
    const Eigen::Vector3f n = p.getNormalVector3fMap();
    ASSERT_NEAR(n.norm(), 1.0F, 1e-4F);
    ASSERT_LE(n.dot(p.getVector3fMap()), 0.0F) << "normal points away from the sensor";
  }
  EXPECT_EQ(voxels.size(), out->size());
  // Points in the middle of the wall at x = 5 have the wall's normal, towards the sensor.
  int wall = 0;
  for (const auto& p : *out) {
    if (p.x > 4.9F && std::abs(p.y) < 3 && p.z > -0.5F && p.z < 1.5F) {
      ++wall;
      EXPECT_NEAR(p.normal_x, -1.0F, 0.02F);
    }
  }
  EXPECT_GT(wall, 50);
}

TEST(ScanPreprocessor, DegenerateNormalFilterDropsGroundCeilingOrBoth) {
  // The sensor is rolled by 20 deg: "up" in its frame is tilted, and the filter follows it.
  const Eigen::Matrix3f roll =
      Eigen::AngleAxisf(0.35F, Eigen::Vector3f::UnitX()).toRotationMatrix();
  Input rolled;
  for (const auto& p : room()) {
    const Eigen::Vector3f q = roll.transpose() * p.getVector3fMap();
    rolled.push_back(xyzi(q.x(), q.y(), q.z()));
  }
  const Eigen::Vector3f up = roll.transpose() * Eigen::Vector3f::UnitZ();
  auto count = [&](HorizontalFilter filter) {
    PreprocessorParams params;
    params.voxel_leaf_m = 0.2;
    params.drop_horizontal = filter;
    int floor = 0;
    int ceiling = 0;
    int walls = 0;
    const auto cloud = ScanPreprocessor(params).process(rolled, up);  // alive for the loop
    for (const auto& p : *cloud) {
      const float height = p.getVector3fMap().dot(up);
      (height < -0.9F ? floor : height > 1.9F ? ceiling : walls)++;
    }
    return std::tuple{floor, ceiling, walls};
  };
  const auto [floor_none, ceiling_none, walls_none] = count(HorizontalFilter::kNone);
  EXPECT_GT(floor_none, 500);
  EXPECT_GT(ceiling_none, 500);
  const auto [floor_ground, ceiling_ground, walls_ground] = count(HorizontalFilter::kGround);
  EXPECT_LT(floor_ground, floor_none / 10);  // only wall points at floor height remain
  // Corner points sit at the threshold, where the last bit of a normal decides: allow a few.
  EXPECT_NEAR(ceiling_ground, ceiling_none, 5);
  const auto [floor_ceiling, ceiling_ceiling, walls_ceiling] = count(HorizontalFilter::kCeiling);
  EXPECT_NEAR(floor_ceiling, floor_none, 5);
  EXPECT_LT(ceiling_ceiling, ceiling_none / 10);
  const auto [floor_both, ceiling_both, walls_both] = count(HorizontalFilter::kBoth);
  EXPECT_LT(floor_both + ceiling_both, (floor_none + ceiling_none) / 10);
  EXPECT_NEAR(walls_both, walls_none, 5);
}

TEST(ScanPreprocessor, SliceModeKeepsAFlattenedBand) {
  PreprocessorParams params;
  params.voxel_leaf_m = 0.1;
  params.slice_mode = true;
  params.slice_min_z_m = -0.2;
  params.slice_max_z_m = 0.3;
  PreprocessStats stats;
  const auto out = ScanPreprocessor(params).process(room(), Eigen::Vector3f::UnitZ(), &stats);
  ASSERT_GT(out->size(), 100U);
  EXPECT_GT(stats.outside_slice, out->size());
  for (const auto& p : *out) {
    ASSERT_EQ(p.z, 0.0F);
    ASSERT_TRUE(std::abs(std::abs(p.x) - 5.0F) < 0.1F || std::abs(std::abs(p.y) - 4.0F) < 0.1F);
  }
}

TEST(ScanPreprocessor, EmptyAndAllInvalidScansGiveEmptyClouds) {
  const ScanPreprocessor preprocessor{PreprocessorParams{}};
  EXPECT_TRUE(preprocessor.process(Input(), Eigen::Vector3f::UnitZ())->empty());
  Input invalid;
  for (int i = 0; i < 100; ++i) invalid.push_back(xyzi(std::nanf(""), 0, 0));
  PreprocessStats stats;
  EXPECT_TRUE(preprocessor.process(invalid, Eigen::Vector3f::UnitZ(), &stats)->empty());
  EXPECT_EQ(stats.not_finite, 100U);
  PreprocessorParams bad;
  bad.normal_radius_m = 0.1;  // below 2 voxels
  EXPECT_THROW(ScanPreprocessor{bad}, std::invalid_argument);
}

TEST(VoxelDownsample, WorksBeyondVoxelGridIndexRange) {
  // 4 km x 4 km x 400 m at 0.1 m is 6.4e12 cells: pcl::VoxelGrid alone would refuse.
  pcl::PointCloud<pcl::PointXYZ> cloud;
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> cell(-20000, 19999);
  std::set<std::tuple<int, int, int>> cells;
  for (int i = 0; i < 3000; ++i) {
    const int x = cell(rng);
    const int y = cell(rng);
    const int z = cell(rng) / 10;
    cells.emplace(x, y, z);
    // Two points inside the same 0.1 m voxel.
    cloud.push_back(pcl::PointXYZ(0.1F * x + 0.03F, 0.1F * y + 0.03F, 0.1F * z + 0.03F));
    cloud.push_back(pcl::PointXYZ(0.1F * x + 0.06F, 0.1F * y + 0.05F, 0.1F * z + 0.04F));
  }
  const auto out = voxelDownsample(cloud, 0.1);
  EXPECT_EQ(out->size(), cells.size());
}

TEST(ScanPreprocessor, RealVelodyneScan) {
  const char* dir = std::getenv("CCIR_DATA_DIR");
  const std::filesystem::path path =
      std::filesystem::path(dir ? dir : CCIR_DEFAULT_DATA_DIR) / "lidar" / "16line_1.pcd";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "SKIPPED: " << path << " not found";
  Input scan;
  ASSERT_EQ(pcl::io::loadPCDFile(path.string(), scan), 0);
  PreprocessStats stats;
  const auto out =
      ScanPreprocessor(PreprocessorParams{}).process(scan, Eigen::Vector3f::UnitZ(), &stats);
  EXPECT_EQ(stats.points_in, 32000U);  // 16 x 2000, organised
  EXPECT_GT(stats.not_finite, 5000U);  // the zero "no return" points
  EXPECT_GT(out->size(), 10000U);
  for (const auto& p : *out) {
    ASSERT_TRUE(p.getVector3fMap().allFinite() && p.getNormalVector3fMap().allFinite());
    ASSERT_NEAR(p.getNormalVector3fMap().norm(), 1.0F, 1e-4F);
  }
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
