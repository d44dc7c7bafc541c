// Parameters of the simulated VLP-16.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::simulation {

struct LidarParams {
  /// Revolutions per second; the stamp of a scan is the start of its sweep.
  double lidar_rate_hz = 10.0;
  /// Firings per revolution and ring (1800 = 0.2 deg at 10 Hz).
  int lidar_columns = 1800;
  double lidar_min_range_m = 0.5;
  double lidar_max_range_m = 100.0;
  /// Standard deviation of the Gaussian range noise.
  double lidar_range_noise_m = 0.03;
  /// Keep no-return beams as NaN points in a 16 x columns cloud instead of dropping them.
  bool lidar_organized = false;

  template <class Self, class Visitor>
  static void fields(Self& p, Visitor& v) {
    v.number("lidar_rate_hz", p.lidar_rate_hz, "Hz", 1.0, 50.0, "lidar revolutions per second");
    v.integer("lidar_columns", p.lidar_columns, "", 16, 7200,
              "firings per revolution and ring (1800: 0.2 deg)");
    v.number("lidar_min_range_m", p.lidar_min_range_m, "m", 0.0, 10.0,
             "nearer returns are dropped");
    v.number("lidar_max_range_m", p.lidar_max_range_m, "m", 1.0, 300.0, "maximum range");
    v.number("lidar_range_noise_m", p.lidar_range_noise_m, "m", 0.0, 1.0,
             "standard deviation of the range noise");
    v.flag("lidar_organized", p.lidar_organized,
           "keep no-return beams as NaN points (16 x columns cloud) instead of dropping them");
  }

  /// Range errors of every field, then constraints().
  std::vector<std::string> validate() const;
  /// Errors of the constraints between fields.
  std::vector<std::string> constraints() const;
};

}  // namespace ccir_mapping::core::simulation
