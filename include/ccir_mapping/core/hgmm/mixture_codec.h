// The wire form of a Gaussian mixture (what a teammate receives instead of a scan): 20 bytes a
// component - weight as uint16, mean as 3 x int16 and the covariance's Cholesky factor as
// 6 x int16, each on a step the mixture chooses from its largest value - after a 13-byte
// header. Decoding rebuilds covariances as L L^T, so they are positive definite whatever the
// rounding. Little-endian.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ccir_mapping/core/hgmm/gaussian_mixture.h"

namespace ccir_mapping::core::hgmm {

constexpr std::size_t kMixtureHeaderBytes = 13;
constexpr std::size_t kMixtureComponentBytes = 20;

std::vector<std::uint8_t> encodeMixture(const GaussianMixture& mixture);

/// Throws std::invalid_argument naming what is wrong (version, length, a zero weight sum).
GaussianMixture decodeMixture(const std::vector<std::uint8_t>& bytes);

}  // namespace ccir_mapping::core::hgmm
