#include "ccir_mapping/core/hgmm/scan_mixture.h"

#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "ccir_mapping/core/hgmm/hgmm.h"
#include "ccir_mapping/core/hgmm/mixture_codec.h"

namespace ccir_mapping::core::hgmm {

std::vector<std::uint8_t> encodeScanMixture(const Points& points, std::size_t max_bytes,
                                            const HgmmParams& params) {
  const Hgmm model = Hgmm::build(points, params);
  const auto level = model.levelWithin(max_bytes);
  if (!level) {
    throw std::invalid_argument("the root mixture takes " + std::to_string(model.bytes(0)) +
                                " bytes, more than " + std::to_string(max_bytes));
  }
  return encodeMixture(model.level(*level));
}

SampledScan sampleScanMixture(const std::vector<std::uint8_t>& bytes, std::size_t n,
                              std::uint64_t seed) {
  const GaussianMixture mixture = decodeMixture(bytes);
  if (mixture.empty() && n > 0)
    throw std::invalid_argument("an empty mixture for " + std::to_string(n) + " points");
  // A surface's Gaussian is flat: its normal is the eigenvector of the smallest eigenvalue
  // (Eigen sorts them in increasing order).
  std::vector<Eigen::Vector3d> axes;
  for (const Gaussian& g : mixture.components()) {
    axes.push_back(
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(g.covariance).eigenvectors().col(0));
  }
  std::mt19937_64 rng(seed);
  std::vector<std::size_t> drawn;
  SampledScan scan;
  scan.points = mixture.sample(n, rng, 7.81, &drawn);
  scan.normals.resize(3, scan.points.cols());
  for (Eigen::Index i = 0; i < scan.points.cols(); ++i) {
    const Eigen::Vector3d& axis = axes[drawn[static_cast<std::size_t>(i)]];
    // Towards the sensor at the origin, as the Preprocessor orients its normals.
    scan.normals.col(i) = axis.dot(scan.points.col(i)) > 0.0 ? Eigen::Vector3d(-axis) : axis;
  }
  return scan;
}

}  // namespace ccir_mapping::core::hgmm
