#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/hwdrivers/CVelodyneScanner.h>
#include <mrpt/obs/CObservationVelodyneScan.h>
#include <mrpt/obs/VelodyneCalibration.h>

namespace ccir_mapping::core::velodyne {
namespace {

constexpr std::int64_t kMicrosecondsPerHour = 3600LL * 1000000LL;

/// libpcap (through MRPT) crashed on a header with a nonsense link type (found by
/// fuzz_pcap_reader): only classic pcap files of Ethernet frames, as Velodyne captures are,
/// reach it.
void checkCaptureHeader(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::uint8_t h[24];
  if (!in.read(reinterpret_cast<char*>(h), sizeof(h))) {
    throw std::runtime_error(file + ": too short for a pcap file header");
  }
  const auto little = [&](int at) {
    return std::uint32_t(h[at]) | std::uint32_t(h[at + 1]) << 8 | std::uint32_t(h[at + 2]) << 16 |
           std::uint32_t(h[at + 3]) << 24;
  };
  const auto swap = [](std::uint32_t v) {
    return (v >> 24) | ((v >> 8) & 0xff00) | ((v << 8) & 0xff0000) | (v << 24);
  };
  const std::uint32_t magic = little(0);
  const bool swapped = magic == 0xd4c3b2a1 || magic == 0x4d3cb2a1;
  if (!swapped && magic != 0xa1b2c3d4 && magic != 0xa1b23c4d) {
    throw std::runtime_error(file + ": not a pcap file (pcapng is not read: convert it with " +
                             "editcap -F pcap)");
  }
  const auto field = [&](int at) { return swapped ? swap(little(at)) : little(at); };
  constexpr std::uint32_t kEthernet = 1;         // DLT_EN10MB
  constexpr std::uint32_t kMaxSnapLen = 262144;  // libpcap's own bound
  if (field(20) != kEthernet) {
    throw std::runtime_error(file + ": link type " + std::to_string(field(20)) +
                             ", not Ethernet (1) as a Velodyne capture is");
  }
  if (field(16) == 0 || field(16) > kMaxSnapLen) {
    throw std::runtime_error(file + ": snapshot length " + std::to_string(field(16)) +
                             " is not a pcap file's");
  }
}

}  // namespace

VelodynePcapReader::VelodynePcapReader(const std::string& pcap_file, const std::string& model,
                                       Stamp start, double min_range_m)
    : scanner_(std::make_unique<mrpt::hwdrivers::CVelodyneScanner>()),
      file_(pcap_file),
      start_(start),
      min_range_m_(min_range_m) {
  if (model != "VLP16" && model != "HDL32" && model != "HDL64") {
    throw std::invalid_argument("unknown Velodyne model '" + model +
                                "': allowed VLP16 | HDL32 | HDL64");
  }
  if (!std::filesystem::is_regular_file(pcap_file)) {
    throw std::runtime_error("cannot read the pcap file " + pcap_file);
  }
  checkCaptureHeader(pcap_file);
  // pcap_read_fast only has a configuration key: read as fast as possible, once.
  mrpt::config::CConfigFileMemory config;
  config.write("velodyne", "model", model);
  config.write("velodyne", "pcap_input", pcap_file);
  config.write("velodyne", "pcap_read_once", std::string("true"));
  config.write("velodyne", "pcap_read_fast", std::string("true"));
  config.write("velodyne", "pcap_read_full_scan_delay_ms", std::string("0"));
  try {
    scanner_->loadConfig(config, "velodyne");
    // The scanner starts with the VLP-16 calibration and keeps it whatever the model says.
    scanner_->setCalibration(mrpt::obs::VelodyneCalibration::LoadDefaultCalibration(model));
    scanner_->setPCAPVerbosity(false);
    scanner_->initialize();
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot decode " + pcap_file + ": " + e.what());
  }
  // Rings count from the lowest elevation up, as the ROS driver numbers them.
  const auto& lasers = scanner_->getCalibration().laser_corrections;
  std::vector<int> order(lasers.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return lasers[a].verticalCorrection < lasers[b].verticalCorrection;
  });
  for (std::size_t ring = 0; ring < order.size(); ++ring) {
    ring_of_laser_[order[ring]] = static_cast<std::uint16_t>(ring);
  }
}

VelodynePcapReader::~VelodynePcapReader() = default;

std::optional<LidarScan> VelodynePcapReader::next() {
  // MRPT's reader does not end on a truncated record: it reports the read error and is asked
  // again, forever (found by fuzz_pcap_reader). A rotation takes ~75 packets on a VLP-16 and
  // ~350 on an HDL-64, so this many reads without one mean the capture is broken.
  constexpr int kMaxReadsWithoutRotation = 1000;
  for (int reads = 0;; ++reads) {
    if (reads == kMaxReadsWithoutRotation) {
      throw std::runtime_error(file_ + ": no rotation in " + std::to_string(reads) +
                               " packet reads after " + std::to_string(rotations_) +
                               " rotation(s): the capture is truncated or not a Velodyne's");
    }
    mrpt::obs::CObservationVelodyneScan::Ptr observation;
    mrpt::obs::CObservationGPS::Ptr gps;
    if (!scanner_->getNextObservation(observation, gps)) return std::nullopt;  // end of file
    if (!observation || observation->scan_packets.empty()) continue;
    ++rotations_;

    // The packet clock counts microseconds within the hour: stamp relative to the first scan.
    const std::uint32_t packet_us = observation->scan_packets.front().gps_timestamp();
    if (!first_packet_us_) first_packet_us_ = packet_us;
    std::int64_t elapsed_us = static_cast<std::int64_t>(packet_us) - *first_packet_us_;
    if (elapsed_us < 0) elapsed_us += kMicrosecondsPerHour;

    mrpt::obs::CObservationVelodyneScan::TGeneratePointCloudParameters options;
    options.minDistance = static_cast<float>(min_range_m_);
    options.generatePerPointTimestamp = true;
    observation->generatePointCloud(options);
    const auto& cloud = observation->point_cloud;

    LidarScan scan;
    scan.stamp = start_ + elapsed_us * 1000;
    scan.rings = rings();
    scan.points.reserve(cloud.size());
    for (std::size_t k = 0; k < cloud.size(); ++k) {
      const auto ring = ring_of_laser_.find(cloud.laser_id[k]);
      if (ring == ring_of_laser_.end()) continue;
      const double time = mrpt::system::timeDifference(observation->timestamp, cloud.timestamp[k]);
      scan.points.push_back(LidarPoint{cloud.x[k], cloud.y[k], cloud.z[k],
                                       static_cast<float>(cloud.intensity[k]), ring->second,
                                       static_cast<float>(time)});
    }
    return scan;
  }
}

}  // namespace ccir_mapping::core::velodyne
