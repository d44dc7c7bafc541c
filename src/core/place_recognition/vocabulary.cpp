#include "ccir_mapping/core/place_recognition/vocabulary.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <flann/flann.hpp>
#include <opencv2/core.hpp>

namespace ccir_mapping::core::place_recognition {
namespace {

using features::kSpinImageBins;
using features::SpinImage;

std::string fnv1a(const std::vector<SpinImage>& words) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const auto& w : words) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(w.data());
    for (std::size_t i = 0; i < sizeof(SpinImage); ++i) {
      h ^= bytes[i];
      h *= 1099511628211ULL;
    }
  }
  std::ostringstream out;
  out << std::hex << std::setw(16) << std::setfill('0') << h;
  return out.str();
}

}  // namespace

Vocabulary::Vocabulary(std::vector<SpinImage> words) : words_(std::move(words)) {
  if (words_.empty()) throw std::invalid_argument("a vocabulary needs at least one word");
  hash_ = fnv1a(words_);
  flann::Matrix<float> data(words_.front().data(), words_.size(), kSpinImageBins);
  index_ = std::make_unique<flann::Index<flann::L2<float>>>(data, flann::KDTreeSingleIndexParams());
  index_->buildIndex();
}

Vocabulary::Vocabulary(Vocabulary&&) noexcept = default;
Vocabulary& Vocabulary::operator=(Vocabulary&&) noexcept = default;
Vocabulary::~Vocabulary() = default;

Vocabulary Vocabulary::train(const std::vector<SpinImage>& descriptors, int words, int seed) {
  if (words < 1 || descriptors.size() < static_cast<std::size_t>(words)) {
    throw std::invalid_argument("vocabulary training needs at least as many descriptors (" +
                                std::to_string(descriptors.size()) + ") as words (" +
                                std::to_string(words) + ")");
  }
  cv::Mat data(static_cast<int>(descriptors.size()), kSpinImageBins, CV_32F);
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    std::copy(descriptors[i].begin(), descriptors[i].end(), data.ptr<float>(static_cast<int>(i)));
  }
  cv::Mat labels;
  cv::Mat centers;
  cv::theRNG().state = static_cast<std::uint64_t>(seed) + 1;
  cv::kmeans(data, words, labels,
             cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4), 2,
             cv::KMEANS_PP_CENTERS, centers);
  std::vector<SpinImage> result(static_cast<std::size_t>(words));
  for (int w = 0; w < words; ++w) {
    std::copy(centers.ptr<float>(w), centers.ptr<float>(w) + kSpinImageBins,
              result[static_cast<std::size_t>(w)].begin());
  }
  return Vocabulary(std::move(result));
}

WordSet Vocabulary::quantize(const std::vector<SpinImage>& descriptors, double max_distance) const {
  WordSet set;
  if (descriptors.empty()) return set;
  flann::Matrix<float> queries(const_cast<float*>(descriptors.front().data()), descriptors.size(),
                               kSpinImageBins);
  std::vector<std::vector<size_t>> indices;
  std::vector<std::vector<float>> squared;
  index_->knnSearch(queries, indices, squared, 1,
                    flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  const double max2 = max_distance * max_distance;
  for (std::size_t i = 0; i < descriptors.size(); ++i) {
    if (!indices[i].empty() && squared[i][0] <= max2) {
      set.push_back(static_cast<std::uint32_t>(indices[i][0]));
    }
  }
  std::sort(set.begin(), set.end());
  set.erase(std::unique(set.begin(), set.end()), set.end());
  return set;
}

void Vocabulary::save(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  out << "ccir_mapping vocabulary 1 " << words_.size() << ' ' << hash_ << '\n';
  out.write(reinterpret_cast<const char*>(words_.front().data()),
            static_cast<std::streamsize>(words_.size() * sizeof(SpinImage)));
  if (!out) throw std::runtime_error("cannot write the vocabulary " + path);
}

Vocabulary Vocabulary::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read the vocabulary " + path);
  std::string header;
  std::getline(in, header);
  std::istringstream fields(header);
  std::string magic;
  std::string kind;
  int version = 0;
  std::size_t count = 0;
  std::string hash;
  if (!(fields >> magic >> kind >> version >> count >> hash) || magic != "ccir_mapping" ||
      kind != "vocabulary" || version != 1 || count == 0) {
    throw std::runtime_error(path + " is not a ccir_mapping vocabulary (version 1)");
  }
  // The words follow the header: a count the file cannot hold is refused before allocating
  // (a corrupt header asked for gigabytes; found by fuzz_vocabulary).
  const std::streampos words_start = in.tellg();
  in.seekg(0, std::ios::end);
  const auto available = static_cast<std::size_t>(in.tellg() - words_start);
  in.seekg(words_start);
  if (count > available / sizeof(SpinImage)) {
    throw std::runtime_error(path + ": truncated (" + std::to_string(count) + " words in " +
                             std::to_string(available) + " bytes)");
  }
  std::vector<SpinImage> words(count);
  in.read(reinterpret_cast<char*>(words.front().data()),
          static_cast<std::streamsize>(count * sizeof(SpinImage)));
  if (!in) throw std::runtime_error(path + ": truncated (" + std::to_string(count) + " words)");
  Vocabulary vocabulary(std::move(words));
  if (vocabulary.hash() != hash) {
    throw std::runtime_error(path + ": content hash " + vocabulary.hash() +
                             " does not match its header's " + hash);
  }
  return vocabulary;
}

}  // namespace ccir_mapping::core::place_recognition
