#include "ccir_mapping/core/place_recognition/chow_liu_tree.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <queue>
#include <sstream>
#include <stdexcept>

namespace ccir_mapping::core::place_recognition {
namespace {

double smooth(double frequency) { return 0.98 * frequency + 0.01; }

/// Mutual information from counts of a, b, both, out of m (raw frequencies).
double informationFromCounts(double n_a, double n_b, double n_ab, double m) {
  const double joint[2][2] = {{m - n_a - n_b + n_ab, n_b - n_ab}, {n_a - n_ab, n_ab}};
  const double pa[2] = {(m - n_a) / m, n_a / m};
  const double pb[2] = {(m - n_b) / m, n_b / m};
  double mi = 0.0;
  for (int u = 0; u < 2; ++u) {
    for (int v = 0; v < 2; ++v) {
      const double p = joint[u][v] / m;
      if (p > 0.0) mi += p * std::log(p / (pa[u] * pb[v]));
    }
  }
  return std::max(0.0, mi);  // rounding can make independent columns a hair negative
}

}  // namespace

ChowLiuTree ChowLiuTree::learn(const std::vector<WordSet>& training, std::size_t vocabulary_size) {
  if (training.empty() || vocabulary_size == 0) {
    throw std::invalid_argument("the Chow-Liu tree needs training word sets and words");
  }
  const std::size_t v = vocabulary_size;
  const double m = static_cast<double>(training.size());
  std::vector<double> count(v, 0.0);
  std::vector<std::uint32_t> together(v * v, 0);  // C = X^T X, the co-occurrence counts
  for (const WordSet& set : training) {
    for (std::size_t i = 0; i < set.size(); ++i) {
      if (set[i] >= v) throw std::invalid_argument("word id outside the vocabulary");
      count[set[i]] += 1.0;
      for (std::size_t j = i + 1; j < set.size(); ++j) {
        ++together[set[i] * v + set[j]];
        ++together[set[j] * v + set[i]];
      }
    }
  }
  auto mi = [&](std::size_t a, std::size_t b) {
    return informationFromCounts(count[a], count[b], together[a * v + b], m);
  };

  // Prim: grow the maximum spanning tree from word 0.
  ChowLiuTree tree;
  tree.parent_.assign(v, 0);
  std::vector<double> best(v, -1.0);
  std::vector<bool> in_tree(v, false);
  in_tree[0] = true;
  for (std::size_t w = 1; w < v; ++w) {
    best[w] = mi(0, w);
    tree.parent_[w] = 0;
  }
  for (std::size_t added = 1; added < v; ++added) {
    std::size_t next = 0;
    double strongest = -1.0;
    for (std::size_t w = 0; w < v; ++w) {
      if (!in_tree[w] && best[w] > strongest) {
        strongest = best[w];
        next = w;
      }
    }
    in_tree[next] = true;
    for (std::size_t w = 0; w < v; ++w) {
      if (in_tree[w]) continue;
      const double value = mi(next, w);
      if (value > best[w]) {
        best[w] = value;
        tree.parent_[w] = static_cast<int>(next);
      }
    }
  }

  tree.marginal_.resize(v);
  tree.given_parent_on_.resize(v);
  tree.given_parent_off_.resize(v);
  for (std::size_t q = 0; q < v; ++q) {
    tree.marginal_[q] = smooth(count[q] / m);
    const auto p = static_cast<std::size_t>(tree.parent_[q]);
    if (p == q) {
      tree.given_parent_on_[q] = tree.given_parent_off_[q] = tree.marginal_[q];
      continue;
    }
    const double both = together[q * v + p];
    const double parent_on = count[p];
    const double parent_off = m - count[p];
    tree.given_parent_on_[q] = parent_on > 0 ? smooth(both / parent_on) : 0.01;
    tree.given_parent_off_[q] = parent_off > 0 ? smooth((count[q] - both) / parent_off) : 0.01;
  }
  tree.linkChildren();
  return tree;
}

void ChowLiuTree::linkChildren() {
  children_.assign(parent_.size(), {});
  for (std::size_t q = 0; q < parent_.size(); ++q) {
    if (parent_[q] != static_cast<int>(q))
      children_[static_cast<std::size_t>(parent_[q])].push_back(static_cast<int>(q));
  }
}

double ChowLiuTree::mutualInformation(const std::vector<WordSet>& training, std::uint32_t a,
                                      std::uint32_t b) {
  double n_a = 0;
  double n_b = 0;
  double n_ab = 0;
  for (const WordSet& set : training) {
    const bool has_a = std::binary_search(set.begin(), set.end(), a);
    const bool has_b = std::binary_search(set.begin(), set.end(), b);
    n_a += has_a;
    n_b += has_b;
    n_ab += has_a && has_b;
  }
  return informationFromCounts(n_a, n_b, n_ab, static_cast<double>(training.size()));
}

void ChowLiuTree::save(const std::string& path, const std::string& vocabulary_hash) const {
  std::ofstream out(path);
  out << "ccir_mapping chow_liu_tree 1 " << size() << ' ' << vocabulary_hash << '\n'
      << std::setprecision(17);
  for (std::size_t q = 0; q < size(); ++q) {
    out << parent_[q] << ' ' << marginal_[q] << ' ' << given_parent_on_[q] << ' '
        << given_parent_off_[q] << '\n';
  }
  if (!out) throw std::runtime_error("cannot write the Chow-Liu tree " + path);
}

ChowLiuTree ChowLiuTree::load(const std::string& path, const std::string& vocabulary_hash,
                              std::size_t vocabulary_size) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read the Chow-Liu tree " + path);
  std::string magic;
  std::string kind;
  int version = 0;
  std::size_t count = 0;
  std::string hash;
  if (!(in >> magic >> kind >> version >> count >> hash) || magic != "ccir_mapping" ||
      kind != "chow_liu_tree" || version != 1 || count == 0) {
    throw std::runtime_error(path + " is not a ccir_mapping Chow-Liu tree (version 1)");
  }
  if (hash != vocabulary_hash) {
    throw std::runtime_error(path + " was learned with vocabulary " + hash + ", not " +
                             vocabulary_hash);
  }
  if (count != vocabulary_size) {  // before allocating what the header announces
    throw std::runtime_error(path + " has " + std::to_string(count) + " words, its vocabulary " +
                             std::to_string(vocabulary_size));
  }
  ChowLiuTree tree;
  tree.parent_.resize(count);
  tree.marginal_.resize(count);
  tree.given_parent_on_.resize(count);
  tree.given_parent_off_.resize(count);
  for (std::size_t q = 0; q < count; ++q) {
    // Probabilities strictly inside (0, 1), as learn() smooths them: FAB-MAP takes their logs.
    const auto probability = [](double p) { return p > 0.0 && p < 1.0; };
    if (!(in >> tree.parent_[q] >> tree.marginal_[q] >> tree.given_parent_on_[q] >>
          tree.given_parent_off_[q]) ||
        tree.parent_[q] < 0 || static_cast<std::size_t>(tree.parent_[q]) >= count ||
        !probability(tree.marginal_[q]) || !probability(tree.given_parent_on_[q]) ||
        !probability(tree.given_parent_off_[q])) {
      throw std::runtime_error(path + ": bad entry for word " + std::to_string(q));
    }
  }
  tree.linkChildren();
  return tree;
}

}  // namespace ccir_mapping::core::place_recognition
