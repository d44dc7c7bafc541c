// FAB-MAP over word sets (Cummins & Newman; structured as openFABMAP): the observation
// likelihood under a Chow-Liu tree and a detector model, a new-place likelihood, and the
// posterior over mapped places. FabMap evaluates every word of every place (FAB-MAP 1.0);
// FabMap2 keeps an inverted index and visits only the postings of observed words and their
// children (FAB-MAP 2.0), with identical posteriors.
// Written here: OpenCV dropped its openFABMAP port after 2.4 and openFABMAP is not packaged for
// Debian; the vocabulary uses OpenCV k-means and FLANN.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "ccir_mapping/core/place_recognition/chow_liu_tree.h"

namespace ccir_mapping::core::place_recognition {

struct FabMapParams {
  /// Detector model: p(z = 1 | e = 1) and p(z = 1 | e = 0).
  double p_z_given_e = 0.39;
  double p_z_given_not_e = 0.0;
  /// Posterior smoothing sigma: p <- sigma p + (1 - sigma) / n.
  double smoothing = 0.99;

  std::vector<std::string> validate() const;
};

/// p(z_q | z_parent, L) for every word, for a place that has (Lz = 1) or lacks (Lz = 0) the
/// word, and for the mean-field average place.
class FabMapModel {
 public:
  enum PlaceWord { kLacks = 0, kHas = 1, kAverage = 2 };
  /// Throws std::invalid_argument when params.validate() reports errors.
  FabMapModel(const ChowLiuTree& tree, const FabMapParams& params);

  double logLikelihood(std::size_t word, bool z, bool z_parent, PlaceWord place) const {
    return table_[word][z][z_parent][place];
  }
  const ChowLiuTree& tree() const { return tree_; }
  const FabMapParams& params() const { return params_; }

 private:
  const ChowLiuTree& tree_;
  FabMapParams params_;
  std::vector<std::array<std::array<std::array<double, 3>, 2>, 2>> table_;
};

/// Normalised, smoothed posterior from log-likelihoods (uniform prior).
std::vector<double> posteriorFromLogLikelihoods(const std::vector<double>& log_likelihoods,
                                                double smoothing);

enum class NewPlaceMethod { kSampled, kMeanField };

/// FAB-MAP 1.0: O(places x words) per query.
class FabMap {
 public:
  /// `samples`: word sets of training keyframes not in the map, for the sampled new-place term.
  FabMap(const FabMapModel& model, std::vector<WordSet> samples,
         NewPlaceMethod new_place = NewPlaceMethod::kSampled);
  void addPlace(const WordSet& words) { places_.push_back(words); }
  std::size_t places() const { return places_.size(); }
  /// log p(Z | L_i) for each place, then log p(Z | L_new).
  std::vector<double> logLikelihoods(const WordSet& observation) const;
  /// p(L_i | Z) for each place, then p(L_new | Z); sums to 1.
  std::vector<double> posterior(const WordSet& observation) const;

 private:
  double logLikelihood(const std::vector<char>& z, const WordSet* place) const;

  const FabMapModel& model_;
  std::vector<WordSet> samples_;
  NewPlaceMethod new_place_;
  std::vector<WordSet> places_;
};

/// FAB-MAP 2.0: likelihoods relative to a place without any word, over an inverted index;
/// the sampled new-place term uses the same index. Posteriors equal FabMap's (sampled).
class FabMap2 {
 public:
  FabMap2(const FabMapModel& model, const std::vector<WordSet>& samples);
  void addPlace(const WordSet& words);
  std::size_t places() const { return default_score_.size() - samples_; }
  /// Relative log-likelihoods: log p(Z | L_i) minus a constant of the query, then the new place.
  std::vector<double> logLikelihoods(const WordSet& observation) const;
  std::vector<double> posterior(const WordSet& observation) const;
  /// For each place, how many words of `observation` it holds (from the inverted index); word
  /// ids outside the vocabulary are ignored.
  std::vector<int> sharedWords(const WordSet& observation) const;

 private:
  void index(const WordSet& words);
  double d(std::size_t word, bool z, bool z_parent) const {
    return model_.logLikelihood(word, z, z_parent, FabMapModel::kHas) -
           model_.logLikelihood(word, z, z_parent, FabMapModel::kLacks);
  }

  const FabMapModel& model_;
  std::size_t samples_ = 0;            // the first samples_ indexed entries are the samples
  std::vector<double> default_score_;  // sum over the entry's words of d(q, 0, 0)
  std::vector<std::vector<std::uint32_t>> postings_;  // word -> entries holding it
};

}  // namespace ccir_mapping::core::place_recognition
