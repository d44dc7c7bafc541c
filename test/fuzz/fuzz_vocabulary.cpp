// libFuzzer target: a place model's vocabulary file (place_recognition/vocabulary.h), the
// binary part of what train_place_model writes and every Matcher loads.
#include <cstdint>
#include <exception>
#include <string>

#include "ccir_mapping/core/place_recognition/vocabulary.h"
#include "file_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = ccir_mapping::fuzz::scratchFile("vocabulary.bin");
  ccir_mapping::fuzz::write(path, data, size);
  try {
    ccir_mapping::core::place_recognition::Vocabulary::load(path);
  } catch (const std::exception&) {
  }
  return 0;
}
