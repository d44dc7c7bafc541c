// libFuzzer target: a place model directory (place_recognition/place_model.h) as
// train_place_model writes it and every Matcher loads it — the Chow-Liu tree, the new-place
// samples and model.yaml drawn from the input, beside a fixed three-word vocabulary. A model
// either is refused with an exception or loads and scores a place with FAB-MAP 2.0 to finite
// log-likelihoods.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>

#include <fuzzer/FuzzedDataProvider.h>

#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "file_input.h"

namespace pr = ccir_mapping::core::place_recognition;

namespace {

void write(const std::string& path, const std::string& text) {
  ccir_mapping::fuzz::write(path, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string dir = [] {
    const std::string model = ccir_mapping::fuzz::scratchFile("model");
    std::filesystem::create_directories(model);
    std::vector<ccir_mapping::core::features::SpinImage> words(3);
    for (std::size_t w = 0; w < words.size(); ++w) words[w].fill(float(w) / 3.0f);
    pr::Vocabulary(words).save(model + "/vocabulary.bin");
    return model;
  }();
  FuzzedDataProvider input(data, size);
  write(dir + "/chow_liu_tree.txt", input.ConsumeRandomLengthString(4096));
  write(dir + "/samples.txt", input.ConsumeRandomLengthString(4096));
  write(dir + "/model.yaml", input.ConsumeRemainingBytesAsString());
  std::shared_ptr<const pr::PlaceModel> model;
  try {
    model = pr::PlaceModel::load(dir);
  } catch (const std::exception&) {
    return 0;
  }
  const pr::FabMapModel fabmap(model->tree, pr::FabMapParams{});
  pr::FabMap2 scorer(fabmap, model->samples);
  scorer.addPlace({0, 1});
  for (const double score : scorer.logLikelihoods({0, 2})) {
    if (!std::isfinite(score)) std::abort();
  }
  return 0;
}
