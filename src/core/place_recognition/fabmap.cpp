#include "ccir_mapping/core/place_recognition/fabmap.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::place_recognition {
namespace {

double logSumExp(const std::vector<double>& values) {
  if (values.empty()) return -std::numeric_limits<double>::infinity();
  const double top = *std::max_element(values.begin(), values.end());
  double sum = 0.0;
  for (double v : values) sum += std::exp(v - top);
  return top + std::log(sum);
}

std::vector<char> dense(const WordSet& words, std::size_t size) {
  std::vector<char> z(size, 0);
  for (const auto w : words) {
    if (w >= size) throw std::invalid_argument("word id outside the vocabulary");
    z[w] = 1;
  }
  return z;
}

}  // namespace

std::vector<std::string> FabMapParams::validate() const {
  ParamCheck check;
  check.inHalfOpenRange("p_z_given_e", p_z_given_e, 0.0, 1.0);
  check.inRange("p_z_given_not_e", p_z_given_not_e, 0.0, 0.5);
  check.require(p_z_given_not_e < p_z_given_e,
                "p_z_given_not_e must be below p_z_given_e (a word is likelier where it exists)");
  check.inRange("smoothing", smoothing, 0.0, 1.0);
  check.inHalfOpenRange("new_place_prior", new_place_prior, 0.0, 1.0);
  check.inRange("motion_prior_weight", motion_prior_weight, 0.0, 1.0);
  return check.errors();
}

FabMapModel::FabMapModel(const ChowLiuTree& tree, const FabMapParams& params)
    : tree_(tree), params_(validated(params)) {
  const double pzge = params.p_z_given_e;
  const double pzgne = params.p_z_given_not_e;
  table_.resize(tree.size());
  for (std::size_t q = 0; q < tree.size(); ++q) {
    const double marginal = tree.marginal(q);
    // p(e = 1 | L) for a place that has the word, lacks it, or the average place.
    const double e_has = pzge * marginal / (pzge * marginal + pzgne * (1 - marginal));
    const double e_lacks =
        (1 - pzge) * marginal / ((1 - pzge) * marginal + (1 - pzgne) * (1 - marginal));
    const double e_place[3] = {e_lacks, e_has, marginal};
    for (int z = 0; z < 2; ++z) {
      for (int zp = 0; zp < 2; ++zp) {
        // p(z = u | e = s, z_parent = v) = beta / (alpha + beta) (algorithms.md section 1.4).
        const double p_u = z ? marginal : 1 - marginal;
        const double p_u_given_parent = z ? tree.conditional(q, zp) : 1 - tree.conditional(q, zp);
        double given_e[2];
        for (int s = 0; s < 2; ++s) {
          const double detect = s ? pzge : pzgne;
          const double p_u_given_e = z ? detect : 1 - detect;
          const double beta = (1 - p_u) * p_u_given_e * p_u_given_parent;
          const double alpha = p_u * (1 - p_u_given_e) * (1 - p_u_given_parent);
          given_e[s] = alpha + beta > 0 ? beta / (alpha + beta) : 0.0;
        }
        for (int place = 0; place < 3; ++place) {
          const double p = given_e[1] * e_place[place] + given_e[0] * (1 - e_place[place]);
          table_[q][z][zp][place] = std::log(std::max(p, 1e-300));
        }
      }
    }
  }
}

std::vector<double> posteriorFromLogLikelihoods(const std::vector<double>& log_likelihoods,
                                                double smoothing,
                                                const std::vector<double>& prior) {
  if (!prior.empty() && prior.size() != log_likelihoods.size()) {
    throw std::invalid_argument("a prior needs one entry per log-likelihood");
  }
  const auto allowed = [&](std::size_t i) { return prior.empty() || prior[i] > 0.0; };
  std::vector<double> joint;  // log p(Z | L_i) p(L_i), of the entries allowed
  for (std::size_t i = 0; i < log_likelihoods.size(); ++i) {
    if (allowed(i))
      joint.push_back(log_likelihoods[i] + (prior.empty() ? 0.0 : std::log(prior[i])));
  }
  const double total = logSumExp(joint);
  const double n = static_cast<double>(joint.size());
  std::vector<double> posterior(log_likelihoods.size(), 0.0);
  for (std::size_t i = 0, j = 0; i < log_likelihoods.size(); ++i) {
    if (allowed(i)) posterior[i] = smoothing * std::exp(joint[j++] - total) + (1 - smoothing) / n;
  }
  return posterior;
}

std::vector<double> placePrior(const std::vector<bool>& eligible,
                               const std::vector<double>& previous, const FabMapParams& params) {
  const std::size_t n = eligible.size();
  const auto eligible_count =
      static_cast<double>(std::count(eligible.begin(), eligible.end(), true));
  std::vector<double> prior(n + 1, 0.0);
  if (eligible_count == 0) {
    prior[n] = 1.0;
    return prior;
  }
  prior[n] = params.new_place_prior;
  // The previous posterior moved along the path: to the next place 0.5, stays 0.25, back 0.25.
  std::vector<double> moved(n, 0.0);
  double moved_total = 0.0;
  const std::size_t previous_places = previous.empty() ? 0 : std::min(previous.size() - 1, n);
  for (std::size_t j = 0; j < previous_places; ++j) {
    const std::pair<std::ptrdiff_t, double> kernel[] = {{1, 0.5}, {0, 0.25}, {-1, 0.25}};
    for (const auto& [step, share] : kernel) {
      const auto i = static_cast<std::ptrdiff_t>(j) + step;
      if (i < 0 || i >= static_cast<std::ptrdiff_t>(n) || !eligible[static_cast<std::size_t>(i)]) {
        continue;
      }
      moved[static_cast<std::size_t>(i)] += previous[j] * share;
      moved_total += previous[j] * share;
    }
  }
  const double following =
      moved_total > 0.0 ? params.motion_prior_weight * (1.0 - previous.back()) : 0.0;
  const double places = 1.0 - params.new_place_prior;
  for (std::size_t i = 0; i < n; ++i) {
    if (!eligible[i]) continue;
    prior[i] = places * ((1.0 - following) / eligible_count +
                         (moved_total > 0.0 ? following * moved[i] / moved_total : 0.0));
  }
  return prior;
}

FabMap::FabMap(const FabMapModel& model, std::vector<WordSet> samples, NewPlaceMethod new_place)
    : model_(model), samples_(std::move(samples)), new_place_(new_place) {
  if (new_place_ == NewPlaceMethod::kSampled && samples_.empty()) {
    throw std::invalid_argument("the sampled new-place term needs training samples");
  }
}

double FabMap::logLikelihood(const std::vector<char>& z, const WordSet* place) const {
  const ChowLiuTree& tree = model_.tree();
  std::vector<char> has;
  if (place) has = dense(*place, tree.size());
  double sum = 0.0;
  for (std::size_t q = 0; q < tree.size(); ++q) {
    const auto kind =
        place ? (has[q] ? FabMapModel::kHas : FabMapModel::kLacks) : FabMapModel::kAverage;
    sum += model_.logLikelihood(q, z[q], z[static_cast<std::size_t>(tree.parent(q))], kind);
  }
  return sum;
}

std::vector<double> FabMap::logLikelihoods(const WordSet& observation) const {
  const std::vector<char> z = dense(observation, model_.tree().size());
  std::vector<double> result;
  for (const WordSet& place : places_) result.push_back(logLikelihood(z, &place));
  if (new_place_ == NewPlaceMethod::kMeanField) {
    result.push_back(logLikelihood(z, nullptr));
  } else {
    std::vector<double> sampled;
    for (const WordSet& sample : samples_) sampled.push_back(logLikelihood(z, &sample));
    result.push_back(logSumExp(sampled) - std::log(static_cast<double>(samples_.size())));
  }
  return result;
}

std::vector<double> FabMap::posterior(const WordSet& observation) const {
  return posteriorFromLogLikelihoods(logLikelihoods(observation), model_.params().smoothing);
}

FabMap2::FabMap2(const FabMapModel& model, const std::vector<WordSet>& samples) : model_(model) {
  if (samples.empty()) throw std::invalid_argument("FAB-MAP 2.0 needs new-place samples");
  postings_.resize(model.tree().size());
  for (const WordSet& sample : samples) index(sample);
  samples_ = samples.size();
}

void FabMap2::index(const WordSet& words) {
  const auto entry = static_cast<std::uint32_t>(default_score_.size());
  double score = 0.0;
  for (const auto w : words) {
    if (w >= postings_.size()) throw std::invalid_argument("word id outside the vocabulary");
    score += d(w, false, false);
    postings_[w].push_back(entry);
  }
  default_score_.push_back(score);
}

void FabMap2::addPlace(const WordSet& words) { index(words); }

std::vector<int> FabMap2::sharedWords(const WordSet& observation) const {
  std::vector<int> shared(places(), 0);
  for (const auto q : observation) {
    if (q >= postings_.size()) continue;
    for (const auto entry : postings_[q]) {
      if (entry >= samples_) ++shared[entry - samples_];
    }
  }
  return shared;
}

std::vector<double> FabMap2::logLikelihoods(const WordSet& observation) const {
  const ChowLiuTree& tree = model_.tree();
  const std::vector<char> z = dense(observation, tree.size());
  std::vector<double> score = default_score_;
  for (const auto q : observation) {
    const bool z_parent = z[static_cast<std::size_t>(tree.parent(q))];
    const double delta = d(q, true, z_parent) - d(q, false, false);
    for (const auto entry : postings_[q]) score[entry] += delta;
    for (const int child : tree.children(q)) {
      if (z[static_cast<std::size_t>(child)]) continue;
      const double child_delta = d(static_cast<std::size_t>(child), false, true) -
                                 d(static_cast<std::size_t>(child), false, false);
      for (const auto entry : postings_[static_cast<std::size_t>(child)])
        score[entry] += child_delta;
    }
  }
  std::vector<double> result(score.begin() + static_cast<std::ptrdiff_t>(samples_), score.end());
  const std::vector<double> sampled(score.begin(),
                                    score.begin() + static_cast<std::ptrdiff_t>(samples_));
  result.push_back(logSumExp(sampled) - std::log(static_cast<double>(samples_)));
  return result;
}

std::vector<double> FabMap2::posterior(const WordSet& observation,
                                       const std::vector<double>& prior) const {
  return posteriorFromLogLikelihoods(logLikelihoods(observation), model_.params().smoothing, prior);
}

}  // namespace ccir_mapping::core::place_recognition
