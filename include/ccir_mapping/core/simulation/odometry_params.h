// Noise of the simulated wheel or visual odometry. Errors accumulate as random walks, so their
// spread after a path does not depend on the odometry rate.
#pragma once

#include <string>
#include <vector>

namespace ccir_mapping::core::simulation {

struct OdometryParams {
  double odom_rate_hz = 50.0;
  /// Standard deviation of the position error, per axis, gained over each metre travelled.
  double odom_noise_m_per_m = 0.02;
  /// Standard deviation of the heading error gained over each metre travelled.
  double odom_noise_rad_per_m = 0.005;
  /// Standard deviation of the heading error gained over each radian turned.
  double odom_noise_rad_per_rad = 0.02;

  template <class Self, class Visitor>
  static void fields(Self& p, Visitor& v) {
    v.number("odom_rate_hz", p.odom_rate_hz, "Hz", 1.0, 1000.0, "odometry and ground truth rate");
    v.number("odom_noise_m_per_m", p.odom_noise_m_per_m, "m/m", 0.0, 1.0,
             "position error (std, per axis) gained per metre travelled");
    v.number("odom_noise_rad_per_m", p.odom_noise_rad_per_m, "rad/m", 0.0, 1.0,
             "heading error (std) gained per metre travelled");
    v.number("odom_noise_rad_per_rad", p.odom_noise_rad_per_rad, "rad/rad", 0.0, 1.0,
             "heading error (std) gained per radian turned");
  }

  bool noiseFree() const {
    return odom_noise_m_per_m == 0.0 && odom_noise_rad_per_m == 0.0 &&
           odom_noise_rad_per_rad == 0.0;
  }
  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::simulation
