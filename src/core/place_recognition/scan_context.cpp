#include "ccir_mapping/core/place_recognition/scan_context.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::place_recognition {
namespace {

/// Column j + shift of a descriptor with `sectors` columns, wrapped around.
Eigen::Index shifted(Eigen::Index j, int shift, Eigen::Index sectors) {
  return ((j + shift) % sectors + sectors) % sectors;
}

double distanceAtShift(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b, int shift) {
  double sum = 0.0;
  int columns = 0;
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    const auto ca = a.col(j);
    const auto cb = b.col(shifted(j, shift, b.cols()));
    const double na = ca.norm(), nb = cb.norm();
    if (na == 0.0 || nb == 0.0) continue;
    sum += 1.0 - ca.dot(cb) / (na * nb);
    ++columns;
  }
  return columns ? sum / columns : 1.0;
}

}  // namespace

std::vector<std::string> ScanContextParams::validate() const {
  ParamCheck check;
  check.inRange("scan_context_rings", rings, 1, 1000);
  check.inRange("scan_context_sectors", sectors, 4, 3600);
  check.inHalfOpenRange("scan_context_max_range_m", max_range_m, 0.0, 1000.0);
  check.inRange("scan_context_height_offset_m", height_offset_m, 0.0, 100.0);
  check.inRange("scan_context_ring_key_candidates", ring_key_candidates, 1, 1000);
  check.inRange("scan_context_shift_search_share", shift_search_share, 0.0, 0.5);
  return check.errors();
}

ScanContext::ScanContext(const pcl::PointCloud<pcl::PointXYZ>& points,
                         const ScanContextParams& params) {
  const ScanContextParams& p = validated(params);
  descriptor_ = Eigen::MatrixXf::Zero(p.rings, p.sectors);
  for (const auto& point : points) {
    if (!std::isfinite(point.x) || !std::isfinite(point.y) || !std::isfinite(point.z)) continue;
    const double range = std::hypot(point.x, point.y);
    if (range >= p.max_range_m) continue;
    const auto ring = static_cast<Eigen::Index>(range / p.max_range_m * p.rings);
    const double azimuth = std::atan2(point.y, point.x) + M_PI;  // [0, 2 pi]
    const auto sector = std::min<Eigen::Index>(
        p.sectors - 1, static_cast<Eigen::Index>(azimuth / (2 * M_PI) * p.sectors));
    const auto height = static_cast<float>(std::max(0.0, point.z + p.height_offset_m));
    descriptor_(ring, sector) = std::max(descriptor_(ring, sector), height);
  }
  ring_key_ = (descriptor_.array() > 0.0F).cast<float>().rowwise().mean();
  sector_key_ = descriptor_.colwise().mean().transpose();
}

ScanContextDistance scanContextDistance(const ScanContext& a, const ScanContext& b,
                                        const ScanContextParams& params) {
  if (a.descriptor().rows() != b.descriptor().rows() ||
      a.descriptor().cols() != b.descriptor().cols()) {
    throw std::invalid_argument("Scan Context descriptors of different grids cannot be compared");
  }
  const Eigen::Index sectors = a.descriptor().cols();
  // The shift that best aligns the sector keys (squared difference), then a search around it.
  int guess = 0;
  double best_key = std::numeric_limits<double>::infinity();
  for (int shift = 0; shift < sectors; ++shift) {
    double d = 0.0;
    for (Eigen::Index j = 0; j < sectors; ++j) {
      const double diff = a.sectorKey()(j) - b.sectorKey()(shifted(j, shift, sectors));
      d += diff * diff;
    }
    if (d < best_key) best_key = d, guess = shift;
  }
  const int radius =
      std::min<int>(static_cast<int>(sectors) / 2,
                    static_cast<int>(std::ceil(params.shift_search_share * sectors)));
  ScanContextDistance best;
  best.distance = std::numeric_limits<double>::infinity();
  for (int offset = -radius; offset <= radius; ++offset) {
    const int shift = static_cast<int>(shifted(guess + offset, 0, sectors));
    const double d = distanceAtShift(a.descriptor(), b.descriptor(), shift);
    if (d < best.distance) best = {d, shift, 0.0};
  }
  // Column j of a meets column j + shift of b: b sees each direction shift sectors further
  // round, so its heading is shift sectors less.
  best.yaw_rad = std::remainder(-2 * M_PI * best.shift / static_cast<double>(sectors), 2 * M_PI);
  return best;
}

}  // namespace ccir_mapping::core::place_recognition
