// Cauchy-Schwarz quadratic mutual information between an occupancy map and one range beam
// (Charrow et al., ICRA 2015), in closed form (algorithms.md section 5.1): no library has it.
#pragma once

#include <vector>

namespace ccir_mapping::core::information {

/// The cells one beam crosses, nearest first.
struct BeamCells {
  /// Occupancy probability of each cell (0.5 where unknown).
  std::vector<double> occupancy;
  /// Distance of each cell's centre from the sensor, increasing.
  std::vector<double> range_m;
  /// The reading when every cell is free (the beam's maximum range).
  double max_range_m = 0.0;
};

/// I_CS(M; Z) of the beam, in nats, >= 0, with Gaussian range noise `sigma_m`. Event pairs
/// farther apart than 6 sigma are skipped (their Gaussian is below 1e-8 of its peak), so the
/// cost is O(C) for sigma below the cell size.
double beamCsqmi(const BeamCells& beam, double sigma_m);

}  // namespace ccir_mapping::core::information
