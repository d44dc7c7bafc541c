#include "ccir_mapping/core/hgmm/mixture_codec.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace ccir_mapping::core::hgmm {
namespace {

constexpr std::uint8_t kVersion = 1;
constexpr double kMaxInt16 = 32767.0;

template <class T>
void put(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the robots are little-endian (x86, ARM)
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

template <class T>
T get(const std::vector<std::uint8_t>& in, std::size_t* at) {
  T value;
  std::memcpy(&value, in.data() + *at, sizeof(T));
  *at += sizeof(T);
  return value;
}

std::int16_t quantise(double value, double step) {
  return static_cast<std::int16_t>(std::clamp(std::round(value / step), -kMaxInt16, kMaxInt16));
}

/// Lower-triangle entries of L, row by row: (0,0) (1,0) (1,1) (2,0) (2,1) (2,2).
constexpr int kLower[6][2] = {{0, 0}, {1, 0}, {1, 1}, {2, 0}, {2, 1}, {2, 2}};

}  // namespace

std::vector<std::uint8_t> encodeMixture(const GaussianMixture& mixture) {
  std::vector<Eigen::Matrix3d> factors;
  double largest_mean = 0.0, largest_factor = 0.0, total = 0.0;
  for (const Gaussian& g : mixture.components()) {
    factors.push_back(Eigen::LLT<Eigen::Matrix3d>(g.covariance).matrixL());
    largest_mean = std::max(largest_mean, g.mean.cwiseAbs().maxCoeff());
    largest_factor = std::max(largest_factor, factors.back().cwiseAbs().maxCoeff());
    total += g.weight;
  }
  const auto mean_step = static_cast<float>(std::max(largest_mean, 1e-6) / kMaxInt16);
  const auto factor_step = static_cast<float>(std::max(largest_factor, 1e-9) / kMaxInt16);
  std::vector<std::uint8_t> out;
  out.reserve(kMixtureHeaderBytes + kMixtureComponentBytes * mixture.size());
  put(out, kVersion);
  put(out, static_cast<std::uint32_t>(mixture.size()));
  put(out, mean_step);
  put(out, factor_step);
  for (std::size_t k = 0; k < mixture.size(); ++k) {
    const Gaussian& g = mixture.components()[k];
    put(out, static_cast<std::uint16_t>(std::lround(g.weight / total * 65535.0)));
    for (int a = 0; a < 3; ++a) put(out, quantise(g.mean(a), mean_step));
    for (const auto& [r, c] : kLower) {
      std::int16_t q = quantise(factors[k](r, c), factor_step);
      if (r == c) q = std::max<std::int16_t>(q, 1);  // positive definite after rounding
      put(out, q);
    }
  }
  return out;
}

GaussianMixture decodeMixture(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < kMixtureHeaderBytes) {
    throw std::invalid_argument("mixture: " + std::to_string(bytes.size()) +
                                " bytes, shorter than its header");
  }
  std::size_t at = 0;
  if (const auto version = get<std::uint8_t>(bytes, &at); version != kVersion) {
    throw std::invalid_argument("mixture: version " + std::to_string(version) + ", expected " +
                                std::to_string(kVersion));
  }
  const auto count = get<std::uint32_t>(bytes, &at);
  const auto mean_step = get<float>(bytes, &at);
  const auto factor_step = get<float>(bytes, &at);
  if (bytes.size() != kMixtureHeaderBytes + kMixtureComponentBytes * std::size_t(count)) {
    throw std::invalid_argument("mixture: " + std::to_string(bytes.size()) + " bytes for " +
                                std::to_string(count) + " components");
  }
  if (!(mean_step > 0.0F) || !(factor_step > 0.0F) || !std::isfinite(mean_step) ||
      !std::isfinite(factor_step)) {
    throw std::invalid_argument("mixture: quantisation steps must be positive and finite");
  }
  std::vector<Gaussian> components(count);
  for (Gaussian& g : components) {
    g.weight = get<std::uint16_t>(bytes, &at) / 65535.0;
    for (int a = 0; a < 3; ++a) g.mean(a) = get<std::int16_t>(bytes, &at) * double(mean_step);
    Eigen::Matrix3d l = Eigen::Matrix3d::Zero();
    for (const auto& [r, c] : kLower) l(r, c) = get<std::int16_t>(bytes, &at) * double(factor_step);
    if (!(l.diagonal().minCoeff() > 0.0)) {
      throw std::invalid_argument("mixture: a covariance factor with a non-positive diagonal");
    }
    g.covariance = l * l.transpose();
  }
  double total = 0.0;
  for (const Gaussian& g : components) total += g.weight;
  if (count > 0 && !(total > 0.0)) throw std::invalid_argument("mixture: the weights sum to zero");
  for (Gaussian& g : components) g.weight /= total;
  return GaussianMixture(std::move(components));
}

}  // namespace ccir_mapping::core::hgmm
