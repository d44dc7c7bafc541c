// A shared keyframe's cloud in the wire form of the Broker's scan_encoding, and back: the one
// pair of functions the Broker nodelet (through conversions) and the team runner both call.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/routing/broker_params.h"

namespace ccir_mapping::core::routing {

using KeyframeCloud = pcl::PointCloud<pcl::PointXYZINormal>;

/// cloud: every point (transport/scan_codec.h); gmm: the HGMM level within
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
