#include "ccir_mapping/core/routing/scan_encoding.h"

#include <stdexcept>

#include "ccir_mapping/core/hgmm/scan_mixture.h"
#include "ccir_mapping/core/routing/scan_codec.h"

namespace ccir_mapping::core::routing {

std::optional<std::vector<std::uint8_t>> encodeKeyframeScan(const KeyframeCloud& cloud,
                                                            const BrokerParams& params,
                                                            std::string* error) {
  if (params.scan_encoding == ScanEncoding::kCloud) {
    return routing::encodeScan(routing::scanPointsOf(cloud), error);
  }
  hgmm::Points points(3, static_cast<Eigen::Index>(cloud.size()));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    points.col(static_cast<Eigen::Index>(i)) = cloud[i].getVector3fMap().cast<double>();
  }
  if (!points.allFinite()) {
    *error = "a point is not finite";
    return std::nullopt;
  }
  try {
    return hgmm::encodeScanMixture(points, static_cast<std::size_t>(params.gmm_max_bytes));
  } catch (const std::invalid_argument& e) {
    *error = e.what();
    return std::nullopt;
  }
}

std::optional<KeyframeCloud> decodeKeyframeScan(const std::vector<std::uint8_t>& bytes,
                                                ScanEncoding encoding, std::size_t point_count,
                                                std::size_t max_points, std::uint64_t seed,
                                                std::string* error) {
  if (point_count > max_points) {
    *error = std::to_string(point_count) + " points, more than " + std::to_string(max_points);
    return std::nullopt;
  }
  KeyframeCloud cloud;
  if (encoding == ScanEncoding::kCloud) {
    const auto points = routing::decodeScan(bytes, max_points, error);
    if (!points) return std::nullopt;
    if (points->size() != point_count) {
      *error = "point_count does not match the points";
      return std::nullopt;
    }
    routing::cloudOf(*points, &cloud);
    return cloud;
  }
  try {
    const hgmm::SampledScan sampled = hgmm::sampleScanMixture(bytes, point_count, seed);
    cloud.resize(point_count);
    for (std::size_t i = 0; i < point_count; ++i) {
      const auto column = static_cast<Eigen::Index>(i);
      cloud[i].getVector3fMap() = sampled.points.col(column).cast<float>();
      cloud[i].getNormalVector3fMap() = sampled.normals.col(column).cast<float>();
      cloud[i].intensity = 0.0F;
    }
    return cloud;
  } catch (const std::invalid_argument& e) {
    *error = e.what();
    return std::nullopt;
  }
}

bool encodeWireScan(const KeyframeCloud& cloud, const BrokerParams& params, WireScan* scan,
                    std::string* error) {
  auto encoded = encodeKeyframeScan(cloud, params, error);
  if (!encoded) return false;
  scan->encoding = params.scan_encoding;
  scan->point_count = static_cast<std::uint32_t>(cloud.size());
  scan->points = std::move(*encoded);
  return true;
}

std::optional<KeyframeCloud> decodeWireScan(const std::vector<std::uint8_t>& points,
                                            ScanEncoding encoding, std::size_t point_count,
                                            KeyframeId id, std::string* error) {
  return decodeKeyframeScan(points, encoding, point_count, kMaxTeammateScanPoints, id, error);
}

}  // namespace ccir_mapping::core::routing
