// libFuzzer target: a shared keyframe scan as it arrives from a teammate, in either encoding
// (transport/scan_codec.h points, hgmm/mixture_codec.h mixtures sampled into points). Decoding
// must return a cloud of exactly the announced size or refuse with a reason.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "ccir_mapping/core/routing/scan_encoding.h"

namespace routing = ccir_mapping::core::routing;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  const auto encoding =
      input.ConsumeBool() ? routing::ScanEncoding::kGmm : routing::ScanEncoding::kCloud;
  const std::size_t count = input.ConsumeIntegralInRange<std::size_t>(0, 5000);
  const std::size_t max_points = input.ConsumeIntegralInRange<std::size_t>(0, 4000);
  const std::uint64_t seed = input.ConsumeIntegral<std::uint64_t>();
  const std::vector<std::uint8_t> bytes = input.ConsumeRemainingBytes<std::uint8_t>();
  std::string error;
  const auto cloud = routing::decodeKeyframeScan(bytes, encoding, count, max_points, seed, &error);
  if (cloud && (cloud->size() != count || count > max_points)) std::abort();
  if (!cloud && error.empty()) std::abort();  // a refusal names its reason
  return 0;
}
