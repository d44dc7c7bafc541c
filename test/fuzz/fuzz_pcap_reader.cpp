// libFuzzer target: a Velodyne capture (velodyne/velodyne_pcap_reader.h, through MRPT's reader),
// as pcap_to_bag reads users' files: every rotation or a clean end or std::exception.
#include <cstdint>
#include <exception>
#include <string>

#include <time.h>

#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "file_input.h"

// MRPT's capture reader pauses 250 ms at the end of a capture read once (it paces real-time
// replays), and every input ends there: the pause capped this target at ~4 inputs a second.
// Waiting is no part of what is fuzzed, so in this binary it returns at once (MRPT's library
// calls nanosleep; the executable's definition takes its place).
extern "C" int nanosleep(const struct timespec*, struct timespec*) { return 0; }

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
