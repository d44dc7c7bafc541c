// The compact scan encoding: a round trip keeps positions within half a millimetre and normals
// within half a degree; a mine-like scan shrinks to well under a fifth of its PointCloud2; every
// malformed input (truncated, flipped bytes, oversized, trailing bytes, non-finite points) is
// refused with a reason and never crashes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "ccir_mapping/core/common/compression.h"
#include "ccir_mapping/core/routing/scan_codec.h"

namespace ccir_mapping::core::routing {
namespace {

/// A 0.1 m voxel-filtered drift of a 4 m wide tunnel, 60 m long, in voxel order (x fastest):
/// walls and floor with their normals, integer intensities.
std::vector<ScanPoint> tunnelScan() {
  std::vector<ScanPoint> points;
  std::mt19937 rng(3);
  std::normal_distribution<float> jitter(0.0f, 0.01f);
  for (int k = 0; k < 30; ++k) {
    for (int j = -20; j <= 20; ++j) {
      for (int i = -300; i < 300; ++i) {
        const bool wall = std::abs(j) == 20 && k > 0;
        const bool floor = k == 0;
        if (!wall && !floor) continue;
        if ((i + j + k) % 3 != 0) continue;  // a sparser return pattern
        ScanPoint p;
        p.x = 0.1f * i + jitter(rng);
        p.y = 0.1f * j + jitter(rng);
        p.z = 0.1f * k - 1.5f + jitter(rng);
        if (wall) {
          p.normal_y = j > 0 ? -1.0f : 1.0f;
        } else {
          p.normal_z = 1.0f;
        }
        p.intensity = static_cast<float>((i * 7 + j * 3) & 0xff);
        points.push_back(p);
      }
    }
  }
  return points;
}

TEST(ScanCodec, RoundTripKeepsGeometryWithinTheQuantisation) {
  const auto points = tunnelScan();
  ASSERT_GT(points.size(), 10000u);
  const auto encoded = encodeScan(points);
  ASSERT_TRUE(encoded);
  const auto decoded = decodeScan(*encoded, points.size());
  ASSERT_TRUE(decoded);
  ASSERT_EQ(decoded->size(), points.size());
  double worst_m = 0.0, worst_normal_rad = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ScanPoint& a = points[i];
    const ScanPoint& b = (*decoded)[i];
    worst_m = std::max({worst_m, std::abs(double(a.x) - b.x), std::abs(double(a.y) - b.y),
                        std::abs(double(a.z) - b.z)});
    const double dot = a.normal_x * b.normal_x + a.normal_y * b.normal_y + a.normal_z * b.normal_z;
    worst_normal_rad = std::max(worst_normal_rad, std::acos(std::min(1.0, dot)));
    EXPECT_EQ(a.intensity, b.intensity);
  }
  EXPECT_LE(worst_m, 0.5 * kScanPositionStepM + 1e-5);
  EXPECT_LT(worst_normal_rad, 0.5 * M_PI / 180.0);
  // PointXYZINormal in a PointCloud2 takes 48 bytes a point.
  const double ratio = double(encoded->size()) / (48.0 * points.size());
  EXPECT_LT(ratio, 0.2) << encoded->size() << " bytes for " << points.size() << " points";
  RecordProperty("bytes_per_point", std::to_string(double(encoded->size()) / points.size()));
}

TEST(ScanCodec, CloudsConvertToScanPointsAndBackFieldByField) {
  struct Point {
    float x, y, z, normal_x, normal_y, normal_z, intensity;
  };
  std::vector<Point> cloud = {{1, 2, 3, 0, 0, 1, 7}, {-4, 5.5F, 6, 1, 0, 0, 255}};
  const std::vector<ScanPoint> points = scanPointsOf(cloud);
  ASSERT_EQ(points.size(), 2U);
  EXPECT_EQ(points[1].y, 5.5F);
  EXPECT_EQ(points[0].normal_z, 1.0F);
  EXPECT_EQ(points[1].intensity, 255.0F);
  std::vector<Point> back;
  cloudOf(points, &back);
  ASSERT_EQ(back.size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(std::memcmp(&back[i], &cloud[i], sizeof(Point)), 0) << i;
  }
}

TEST(ScanCodec, EmptyScanRoundTrips) {
  const auto encoded = encodeScan({});
  ASSERT_TRUE(encoded);
  const auto decoded = decodeScan(*encoded, 10);
  ASSERT_TRUE(decoded);
  EXPECT_TRUE(decoded->empty());
}

TEST(ScanCodec, RefusesNonFiniteAndFarPoints) {
  std::string error;
  std::vector<ScanPoint> points(3);
  points[1].y = std::nanf("");
  EXPECT_FALSE(encodeScan(points, &error));
  EXPECT_NE(error.find("point 1"), std::string::npos) << error;
  points[1].y = 2e6f;
  EXPECT_FALSE(encodeScan(points, &error));
}

TEST(ScanCodec, RefusesMalformedInputByReasonAndNeverCrashes) {
  auto points = tunnelScan();
  points.resize(500);
  const auto encoded = *encodeScan(points);
  std::string error;
  EXPECT_FALSE(decodeScan(encoded, 499, &error)) << "more points than allowed";
  EXPECT_FALSE(error.empty());
  EXPECT_FALSE(decodeScan({}, 500, &error));
  auto truncated = encoded;
  truncated.resize(truncated.size() / 2);
  EXPECT_FALSE(decodeScan(truncated, 500, &error));

  // Valid zstd around bad contents: truncated planes, trailing bytes, another version.
  std::vector<std::uint8_t> raw = *decompress(encoded, 1 << 20);
  auto reencode = [](std::vector<std::uint8_t> r) { return compress(r); };
  auto cut = raw;
  cut.pop_back();
  EXPECT_FALSE(decodeScan(reencode(cut), 500, &error));
  EXPECT_EQ(error, "truncated intensities");
  auto longer = raw;
  longer.push_back(0);
  EXPECT_FALSE(decodeScan(reencode(longer), 500, &error));
  EXPECT_EQ(error, "trailing bytes");
  auto other = raw;
  other[0] = 99;
  EXPECT_FALSE(decodeScan(reencode(other), 500, &error));
  EXPECT_EQ(error, "unknown encoding version");
  // Regression (fuzz_scan_decoding): a step of -2^63 mm overflowed the position's sum.
  std::vector<std::uint8_t> far = {raw[0], 1};  // the version, one point
  far.insert(far.end(), 9, 0xff);
  far.push_back(0x01);  // varint 2^64 - 1: zigzag of -2^63
  EXPECT_FALSE(decodeScan(reencode(far), 500, &error));
  EXPECT_EQ(error, "a position beyond 1000 km");

  // Random corruption of the raw contents: refused or decoded to at most 500 points, never
  // a crash.
  std::mt19937 rng(11);
  for (int trial = 0; trial < 2000; ++trial) {
    auto bad = raw;
    const int flips = 1 + trial % 8;
    for (int f = 0; f < flips; ++f)
      bad[rng() % bad.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    if (trial % 5 == 0) bad.resize(rng() % bad.size());
    const auto decoded = decodeScan(reencode(bad), 500);
    if (decoded) EXPECT_LE(decoded->size(), 500u);
  }
}

}  // namespace
}  // namespace ccir_mapping::core::routing
