// A keyframe scan sent as a Gaussian mixture instead of points (the Broker's scan_encoding gmm,
// thesis chapter 6): the sender fits the scan's HGMM and sends the deepest level within a byte
// budget; the receiver draws as many points as the scan had, each with the normal of the
// Gaussian it came from (its flattest axis, turned towards the sensor), so that the scan is
// mapped, described and verified like a received cloud.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ccir_mapping/core/hgmm/gaussian_mixture.h"
#include "ccir_mapping/core/hgmm/hgmm_params.h"

namespace ccir_mapping::core::hgmm {

/// The wire form (mixture_codec.h) of the deepest level of `points`' HGMM (sensor frame) that
/// fits `max_bytes`. Throws std::invalid_argument when there are no points, the params are
/// invalid or not even the root level fits.
std::vector<std::uint8_t> encodeScanMixture(const Points& points, std::size_t max_bytes,
                                            const HgmmParams& params = {});

struct SampledScan {
  Points points;
  Points normals;  // unit, one per point
};

/// `n` points drawn from a wire form, the same for the same `seed`. Throws
/// std::invalid_argument when the bytes are no mixture (mixture_codec.h's reasons) or an empty
/// one while points are asked for.
SampledScan sampleScanMixture(const std::vector<std::uint8_t>& bytes, std::size_t n,
                              std::uint64_t seed);

}  // namespace ccir_mapping::core::hgmm
