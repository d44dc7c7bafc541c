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
  /// Posterior smoothing sigma: p <- sigma p + (1 - sigma) / n over the n places that may
  /// hold mass and the new place.
  double smoothing = 0.99;
  /// p(L_new) before the observation (openFABMAP and the paper: 0.9): most scans are of places
  /// not yet mapped, and a uniform prior would give "new" only 1 / (places + 1) of it however
  /// unfamiliar the scan.
  double new_place_prior = 0.9;
  /// Motion prior (placePrior): of the mapped places' share, this much, times the previous
  /// query's belief in a mapped place (1 - its p(new)), follows that query's posterior to the
  /// neighbouring places; the rest is uniform. 0: uniform.
  double motion_prior_weight = 0.5;

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

/// Normalised, smoothed posterior from log-likelihoods and a prior with one entry for each (a
/// place whose prior is 0 is excluded before normalising and gets no mass, also from the
/// smoothing); an empty prior is uniform.
std::vector<double> posteriorFromLogLikelihoods(const std::vector<double>& log_likelihoods,
                                                double smoothing,
                                                const std::vector<double>& prior = {});

/// FAB-MAP's prior p(L_i | Z^{k-1}) over places 0..n-1 along one robot's path (eligible[i]:
/// it may be matched; the others get 0) and then the new place, which gets new_place_prior
/// (1 when no place is eligible). The places' share is uniform over the eligible ones, except
/// for motion_prior_weight x (1 - previous p(new)) of it that follows `previous` (the posterior
/// of the query before, over the first previous.size() - 1 places then new; empty: none) to
/// neighbouring places: the next one 0.5, the same one and the one before 0.25 each (the
/// forward bias of openFABMAP's motion model), renormalised over the eligible places, which
/// openFABMAP omits. Sums to 1.
std::vector<double> placePrior(const std::vector<bool>& eligible,
                               const std::vector<double>& previous, const FabMapParams& params);

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
  /// p(L_i | Z) for each place, then p(L_new | Z), under `prior` (placePrior; empty: uniform).
  std::vector<double> posterior(const WordSet& observation,
                                const std::vector<double>& prior = {}) const;
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
