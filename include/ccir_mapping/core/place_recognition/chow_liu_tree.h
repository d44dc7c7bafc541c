// The Chow-Liu tree over word occurrences: the maximum-mutual-information spanning tree, with
// smoothed marginals and conditionals (FAB-MAP's appearance prior, algorithms.md section 1.3).
// Written here: none of our libraries learns a Chow-Liu tree (openFABMAP is not packaged for
// Debian), and a dense Prim over mutual information computed on the fly needs no V x V edge list,
// which Boost Graph's Prim would.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/place_recognition/vocabulary.h"

namespace ccir_mapping::core::place_recognition {

class ChowLiuTree {
 public:
  /// Learns from the word sets of training keyframes (disjoint from the places to recognise,
  /// without revisits). Prim's algorithm with mutual information computed on the fly from a
  /// co-occurrence count table (V x V); throws std::invalid_argument for an empty training set
  /// or a word id outside the vocabulary.
  static ChowLiuTree learn(const std::vector<WordSet>& training, std::size_t vocabulary_size);

  std::size_t size() const { return parent_.size(); }
  /// The root is its own parent.
  int parent(std::size_t word) const { return parent_[word]; }
  const std::vector<int>& children(std::size_t word) const { return children_[word]; }
  /// p(z_q = 1), smoothed into [0.01, 0.99].
  double marginal(std::size_t word) const { return marginal_[word]; }
  /// p(z_q = 1 | z_parent = parent_value), smoothed (the marginal for the root).
  double conditional(std::size_t word, bool parent_value) const {
    return parent_value ? given_parent_on_[word] : given_parent_off_[word];
  }

  /// Mutual information of two word columns of `training` (nats, raw frequencies, >= 0).
  static double mutualInformation(const std::vector<WordSet>& training, std::uint32_t a,
                                  std::uint32_t b);

  /// "ccir_mapping chow_liu_tree 1 <words> <vocabulary hash>" then one line per word: parent,
  /// marginal, conditional given parent on, given parent off. Throws std::runtime_error naming the
  /// file; load() also when the vocabulary hash differs from `vocabulary_hash`, the words from
  /// `vocabulary_size`, or a probability is not strictly inside (0, 1).
  void save(const std::string& path, const std::string& vocabulary_hash) const;
  static ChowLiuTree load(const std::string& path, const std::string& vocabulary_hash,
                          std::size_t vocabulary_size);

 private:
  void linkChildren();

  std::vector<int> parent_;
  std::vector<std::vector<int>> children_;
  std::vector<double> marginal_;
  std::vector<double> given_parent_on_;
  std::vector<double> given_parent_off_;
};

}  // namespace ccir_mapping::core::place_recognition
