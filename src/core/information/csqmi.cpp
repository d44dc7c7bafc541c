#include "ccir_mapping/core/information/csqmi.h"

#include <algorithm>
#include <cmath>

namespace ccir_mapping::core::information {
namespace {

/// Zero-mean Gaussian density with variance `variance` at x.
double gaussian(double x, double variance) {
  return std::exp(-0.5 * x * x / variance) / std::sqrt(2.0 * M_PI * variance);
}

}  // namespace

double beamCsqmi(const BeamCells& beam, double sigma_m) {
  const std::size_t cells = beam.occupancy.size();
  if (cells == 0) return 0.0;
  // Events 0..C-1: cell i is the first occupied one; event C: all free (max-range reading).
  const std::size_t events = cells + 1;
  std::vector<double> p(events);
  std::vector<double> range(events);
  std::vector<double> weight(events);
  double all_free = 1.0;
  for (std::size_t i = 0; i < cells; ++i) {
    p[i] = beam.occupancy[i] * all_free;
    range[i] = beam.range_m[i];
    all_free *= 1.0 - beam.occupancy[i];
  }
  p[cells] = all_free;
  range[cells] = beam.max_range_m;
  // w_i = p(e_i)^2 * prod_{j>i} (o_j^2 + (1 - o_j)^2); w_all_free = p(e_all_free)^2.
  weight[cells] = all_free * all_free;
  double tail = 1.0;
  for (std::size_t i = cells; i-- > 0;) {
    weight[i] = p[i] * p[i] * tail;
    const double o = beam.occupancy[i];
    tail *= o * o + (1 - o) * (1 - o);
  }
  const double variance = 2.0 * sigma_m * sigma_m;
  const double reach = 6.0 * sigma_m * std::sqrt(2.0);
  double sum_w = 0.0;
  double cross_pp = 0.0;
  double cross_wp = 0.0;
  for (std::size_t i = 0; i < events; ++i) {
    sum_w += weight[i];
    // Ranges increase with the index, so only a band of j >= i is within reach of i; each pair
    // j > i stands for (i, j) and (j, i).
    for (std::size_t j = i; j < events && range[j] - range[i] <= reach; ++j) {
      const double g = gaussian(range[i] - range[j], variance);
      const double twice = i == j ? 1.0 : 2.0;
      cross_pp += twice * p[i] * p[j] * g;
      cross_wp += (weight[i] * p[j] + (i == j ? 0.0 : weight[j] * p[i])) * g;
    }
  }
  const double value = std::log(gaussian(0.0, variance) * sum_w) + std::log(tail * cross_pp) -
                       2.0 * std::log(cross_wp);
  return std::max(0.0, value);
}

}  // namespace ccir_mapping::core::information
