// A shared keyframe in the wire form of the Broker's scan_encoding, and back: the functions the
// Broker nodelet (through conversions) and the team runner both call.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/routing/broker_params.h"

namespace ccir_mapping::core::routing {

using KeyframeCloud = pcl::PointCloud<pcl::PointXYZINormal>;

/// A keyframe as the Broker sends it (SharedScan): its points encoded, and what a teammate
/// needs to place them.
struct WireScan {
  std::string robot;
  KeyframeId id = 0;
  Stamp stamp = 0;
  Pose3 odom_pose = Pose3::Identity();
  float travelled_m = 0.0F;
  float rotated_rad = 0.0F;
  ScanEncoding encoding = ScanEncoding::kCloud;
  std::uint32_t point_count = 0;
  std::vector<std::uint8_t> points;
};

/// Most points a teammate's scan may decode to (a VLP-16 sweep has ~29 k before filtering): what
/// a teammate can make this robot allocate.
constexpr std::size_t kMaxTeammateScanPoints = 1 << 20;

/// Sets `scan`'s encoding, point count and points to `cloud` encoded in params.scan_encoding
/// (encodeKeyframeScan); false, with `error` set and `scan` unchanged, when it cannot carry it.
bool encodeWireScan(const KeyframeCloud& cloud, const BrokerParams& params, WireScan* scan,
                    std::string* error);
/// A teammate's scan decoded (decodeKeyframeScan: at most kMaxTeammateScanPoints, a mixture
/// sampled with the keyframe's id as seed).
std::optional<KeyframeCloud> decodeWireScan(const std::vector<std::uint8_t>& points,
                                            ScanEncoding encoding, std::size_t point_count,
                                            KeyframeId id, std::string* error);

/// cloud: every point (routing/scan_codec.h); gmm: the HGMM level within
/// params.gmm_max_bytes (hgmm/scan_mixture.h). nullopt with `error` set for a cloud the
/// encoding cannot carry (a non-finite value; no points for gmm).
std::optional<std::vector<std::uint8_t>> encodeKeyframeScan(const KeyframeCloud& cloud,
                                                            const BrokerParams& params,
                                                            std::string* error);

/// The cloud of `point_count` points (cloud: decoded; gmm: sampled with `seed`, intensity 0),
/// or nullopt with `error` set for bytes that are no such encoding, a count that does not match
/// them, or more than `max_points`.
std::optional<KeyframeCloud> decodeKeyframeScan(const std::vector<std::uint8_t>& bytes,
                                                ScanEncoding encoding, std::size_t point_count,
                                                std::size_t max_points, std::uint64_t seed,
                                                std::string* error);

}  // namespace ccir_mapping::core::routing
