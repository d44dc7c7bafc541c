// libFuzzer target: a Velodyne capture (velodyne/velodyne_pcap_reader.h, through MRPT's reader),
// as pcap_to_bag reads users' files: every rotation or a clean end or std::exception.
#include <cstdint>
#include <exception>
#include <string>

#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "file_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = ccir_mapping::fuzz::scratchFile("capture.pcap");
  ccir_mapping::fuzz::write(path, data, size);
  try {
    ccir_mapping::core::velodyne::VelodynePcapReader reader(path, "VLP16",
                                                            ccir_mapping::core::Stamp{});
    for (int scans = 0; scans < 100 && reader.next(); ++scans) {
    }
  } catch (const std::exception&) {
  }
  return 0;
}
