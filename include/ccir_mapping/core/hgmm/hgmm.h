// A hierarchy of Gaussian mixtures over one cloud (Srivastava & Michael, T-RO 2019; built
// top-down as in HGMR, Eckart et al. 2018; algorithms.md section 6.2). Level 0 is one EM fit;
// a node is split by an EM fit to the points most likely under it, and the split is kept only
// when the Bayesian information criterion prefers the children (Schwarz 1978): twice the gain in
// log-likelihood of the node's points must exceed the extra parameters times ln(points). Child
// weights are multiplied by the parent's, so every level is a normalised mixture.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "ccir_mapping/core/hgmm/gaussian_mixture.h"
#include "ccir_mapping/core/hgmm/hgmm_params.h"
#include "ccir_mapping/core/hgmm/mixture_codec.h"

namespace ccir_mapping::core::hgmm {

struct HgmmNode {
  Gaussian gaussian;  // weight relative to the whole cloud
  int parent = -1;    // -1 at level 0
  int depth = 0;
  std::vector<int> children;
  std::size_t points = 0;  // points assigned to it when it was fitted
};

class Hgmm {
 public:
  /// Throws std::invalid_argument for invalid params or no points.
  static Hgmm build(const Points& points, const HgmmParams& params);

  const std::vector<HgmmNode>& nodes() const { return nodes_; }
  /// Deepest level present.
  int depth() const { return depth_; }
  /// The nodes at `level` and the leaves above it: a normalised mixture for any level >= 0
  /// (levels below depth() equal depth()).
  GaussianMixture level(int level) const;
  std::size_t components(int level) const;
  /// Size of the level's wire form (mixture_codec.h).
  std::size_t bytes(int level) const {
    return kMixtureHeaderBytes + kMixtureComponentBytes * components(level);
  }
  /// The deepest level that fits `budget_bytes`; nullopt when even level 0 does not.
  std::optional<int> levelWithin(std::size_t budget_bytes) const;

 private:
  std::vector<int> levelNodes(int level) const;

  std::vector<HgmmNode> nodes_;
  int depth_ = 0;
};

}  // namespace ccir_mapping::core::hgmm
