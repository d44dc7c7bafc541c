// Compact wire form of a shared keyframe scan: what a teammate needs to map it and to verify a
// loop closure against it (positions, normals, intensity): ~59 KB for a ~500 KB PointCloud2 of a
// simulated VLP-16 keyframe.
//
// Positions are fixed-point at 1 mm in the sensor frame (the voxel filter has already put
// points 0.1 m apart, and the sensor is good to ~3 cm), delta-coded from point to point in the
// scan's order as zig-zag varints (the voxel filter's order keeps neighbours close), normals as
// three int8 at 1/127, intensity as uint8 (a VLP-16 reports integers 0..255), each in a plane of
// its own; then zstd. No library encodes PCL clouds this way without a dependency we lack
// (draco, PCL's octree compression loses points), so it is written here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ccir_mapping::core::routing {

struct ScanPoint {
  float x = 0, y = 0, z = 0;
  float normal_x = 0, normal_y = 0, normal_z = 0;
  float intensity = 0;
};

/// The points of a cloud with x y z, normal_x/y/z and intensity (a PCL PointXYZINormal cloud:
/// anything with size() and operator[]), in the codec's layout.
template <class Cloud>
std::vector<ScanPoint> scanPointsOf(const Cloud& cloud) {
  std::vector<ScanPoint> points(cloud.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = cloud[i];
    points[i] = {p.x, p.y, p.z, p.normal_x, p.normal_y, p.normal_z, p.intensity};
  }
  return points;
}

/// The same back into such a cloud (resized to the points).
template <class Cloud>
void cloudOf(const std::vector<ScanPoint>& points, Cloud* cloud) {
  cloud->resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ScanPoint& p = points[i];
    auto& q = (*cloud)[i];
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.normal_x = p.normal_x;
    q.normal_y = p.normal_y;
    q.normal_z = p.normal_z;
    q.intensity = p.intensity;
  }
}

/// Steps of the quantisation (the largest error is half of each).
constexpr double kScanPositionStepM = 0.001;
constexpr double kScanNormalStep = 1.0 / 127.0;

/// The encoded scan, or nullopt (with `error` set when given) for a non-finite value or a
/// coordinate beyond +-1000 km.
std::optional<std::vector<std::uint8_t>> encodeScan(const std::vector<ScanPoint>& points,
                                                    std::string* error = nullptr);
/// The points, or nullopt with the reason for anything that is not one complete encoding of
/// at most `max_points` points (truncated, oversized, trailing bytes, unknown version).
std::optional<std::vector<ScanPoint>> decodeScan(const std::vector<std::uint8_t>& bytes,
                                                 std::size_t max_points,
                                                 std::string* error = nullptr);

}  // namespace ccir_mapping::core::routing
