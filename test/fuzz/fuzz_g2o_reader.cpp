// libFuzzer target: a g2o pose-graph file (backend/g2o_io.h), as users hand them to
// pgo_benchmark and the Backend. Reading must give a graph or throw std::exception.

#include <cstdint>
#include <exception>
#include <string>

#include "ccir_mapping/core/pose_graph/g2o_io.h"
#include "file_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = ccir_mapping::fuzz::scratchFile("graph.g2o");
  ccir_mapping::fuzz::write(path, data, size);
  try {
    ccir_mapping::core::pose_graph::readG2o(path);
  } catch (const std::exception&) {
  }
  return 0;
}
