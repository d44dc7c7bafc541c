// Decodes Velodyne packet captures (pcap) into scans with MRPT's driver, for users without the
// Velodyne ROS driver and for tests on real packets.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "ccir_mapping/core/common/lidar_scan.h"

namespace mrpt::hwdrivers {
class CVelodyneScanner;
}

namespace ccir_mapping::core::velodyne {

class VelodynePcapReader {
 public:
  /// `model` is MRPT's name ("VLP16", "HDL32"): it is given, never read from the packets, whose
  /// factory byte can be wrong. Scans are stamped from the sensor's packet clock, relative to
  /// the first scan, starting at `start`. Throws std::runtime_error naming the file when it
  /// cannot be opened, std::invalid_argument for an unknown model.
  VelodynePcapReader(const std::string& pcap_file, const std::string& model, Stamp start,
                     double min_range_m = 0.4);
  ~VelodynePcapReader();

  /// The next rotation (x y z intensity ring time, dropped no-returns), or nullopt at the end
  /// of the file. A capture starting mid-rotation yields that partial rotation first. Throws
  /// std::runtime_error naming the file when it breaks off in a truncated packet record (the
  /// rotations before it have been returned).
  std::optional<LidarScan> next();

  /// Rings of the model (16 for a VLP-16).
  int rings() const { return static_cast<int>(ring_of_laser_.size()); }

 private:
  std::unique_ptr<mrpt::hwdrivers::CVelodyneScanner> scanner_;
  std::string file_;
  Stamp start_;
  double min_range_m_;
  /// Ring (0 = lowest elevation) of each laser id, from the model's calibration.
  std::map<int, std::uint16_t> ring_of_laser_;
  std::optional<std::uint32_t> first_packet_us_;
  std::size_t rotations_ = 0;
};

}  // namespace ccir_mapping::core::velodyne
