// The visual (here: geometric) vocabulary: spin-image words, quantisation of a keyframe's
// descriptors into the set of words it contains, and a versioned file with a content hash.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "ccir_mapping/core/features/local_features.h"

namespace flann {
template <typename Distance>
class Index;
template <class T>
struct L2;
}  // namespace flann

namespace ccir_mapping::core::place_recognition {

/// Sorted, unique ids of the words present in a keyframe (FAB-MAP's observation z).
using WordSet = std::vector<std::uint32_t>;

class Vocabulary {
 public:
  explicit Vocabulary(std::vector<features::SpinImage> words);
  Vocabulary(Vocabulary&&) noexcept;
  Vocabulary& operator=(Vocabulary&&) noexcept;
  ~Vocabulary();

  /// k-means (OpenCV, k-means++ seeding, fixed seed) of training descriptors into `words` words.
  /// Throws std::invalid_argument with fewer descriptors than words.
  static Vocabulary train(const std::vector<features::SpinImage>& descriptors, int words,
                          int seed = 1);

  /// The words of the nearest centre (exact FLANN kd-tree) of every descriptor closer than
  /// `max_distance`.
  WordSet quantize(const std::vector<features::SpinImage>& descriptors,
                   double max_distance = std::numeric_limits<double>::infinity()) const;

  std::size_t size() const { return words_.size(); }
  const std::vector<features::SpinImage>& words() const { return words_; }
  /// Hex FNV-1a 64 of the words' bytes: every message carrying word ids carries it, and teammates
  /// with another vocabulary refuse them.
  const std::string& hash() const { return hash_; }

  /// "ccir_mapping vocabulary 1 <words> <hash>" then the words as float32. Throws
  /// std::runtime_error naming the file on I/O or format errors, or a hash mismatch.
  void save(const std::string& path) const;
  static Vocabulary load(const std::string& path);

 private:
  std::vector<features::SpinImage> words_;
  std::string hash_;
  std::unique_ptr<flann::Index<flann::L2<float>>> index_;
};

}  // namespace ccir_mapping::core::place_recognition
