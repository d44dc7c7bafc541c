// Place recognition (algorithms.md section 1.10): Chow-Liu recovery of a known tree, mutual
// information, probability axioms of the FAB-MAP likelihood, posteriors, FAB-MAP 2.0 equal to
// 1.0, vocabulary training, quantisation and files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <set>

#include <pcl/io/pcd_io.h>

#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/histogram_matcher.h"
#include "ccir_mapping/core/place_recognition/scan_context_index.h"

namespace ccir_mapping::core::place_recognition {
namespace {

/// Word sets sampled from a chain 0 -> 1 -> ... -> 7 (strong conditionals), word 8 independent
/// of everything, and words 9..11 rare.
std::vector<WordSet> chainSamples(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<WordSet> sets;
  for (int k = 0; k < count; ++k) {
    WordSet set;
    bool previous = u(rng) < 0.5;
    if (previous) set.push_back(0);
    for (std::uint32_t w = 1; w < 8; ++w) {
      const bool on = u(rng) < (previous ? 0.9 : 0.1);
      if (on) set.push_back(w);
      previous = on;
    }
    if (u(rng) < 0.5) set.push_back(8);
    for (std::uint32_t w = 9; w < 12; ++w) {
      if (u(rng) < 0.05) set.push_back(w);
    }
    sets.push_back(set);
  }
  return sets;
}

TEST(ChowLiu, RecoversAKnownChain) {
  const auto training = chainSamples(5000, 1);
  const ChowLiuTree tree = ChowLiuTree::learn(training, 12);
  ASSERT_EQ(tree.size(), 12U);
  int roots = 0;
  for (std::size_t q = 0; q < tree.size(); ++q) roots += tree.parent(q) == static_cast<int>(q);
  EXPECT_EQ(roots, 1);  // a spanning tree: V - 1 edges
  for (std::uint32_t w = 1; w < 8; ++w) {
    const bool edge =
        tree.parent(w) == static_cast<int>(w - 1) || tree.parent(w - 1) == static_cast<int>(w);
    EXPECT_TRUE(edge) << "chain edge " << w - 1 << " - " << w << " not recovered";
  }
  // Conditionals follow the chain: a word given its parent on is likelier than given off.
  for (std::uint32_t w = 1; w < 8; ++w) {
    EXPECT_GT(tree.conditional(w, true), tree.conditional(w, false) + 0.5) << w;
  }
  for (std::size_t q = 0; q < tree.size(); ++q) {
    for (bool v : {false, true}) {
      EXPECT_GE(tree.conditional(q, v), 0.01);
      EXPECT_LE(tree.conditional(q, v), 0.99);
    }
  }
}

TEST(ChowLiu, MutualInformationIsSymmetricAndZeroForIndependentWords) {
  // Word 0 in the first half, word 1 in every other set: exactly independent counts.
  std::vector<WordSet> sets;
  for (int k = 0; k < 100; ++k) {
    WordSet s;
    if (k < 50) s.push_back(0);
    if (k % 2 == 0) s.push_back(1);
    sets.push_back(s);
  }
  EXPECT_NEAR(ChowLiuTree::mutualInformation(sets, 0, 1), 0.0, 1e-15);
  const auto chain = chainSamples(2000, 2);
  const double ab = ChowLiuTree::mutualInformation(chain, 2, 3);
  EXPECT_GT(ab, 0.1);
  EXPECT_DOUBLE_EQ(ab, ChowLiuTree::mutualInformation(chain, 3, 2));
}

class Fabmap : public ::testing::Test {
 protected:
  Fabmap()
      : training_(chainSamples(2000, 3)),
        tree_(ChowLiuTree::learn(training_, 12)),
        model_(tree_, FabMapParams{}) {}
  std::vector<WordSet> training_;
  ChowLiuTree tree_;
  FabMapModel model_;
};

TEST_F(Fabmap, LikelihoodsOfBothValuesSumToOne) {
  for (std::size_t q = 0; q < tree_.size(); ++q) {
    for (bool zp : {false, true}) {
      for (auto place : {FabMapModel::kLacks, FabMapModel::kHas, FabMapModel::kAverage}) {
        const double sum = std::exp(model_.logLikelihood(q, false, zp, place)) +
                           std::exp(model_.logLikelihood(q, true, zp, place));
        ASSERT_NEAR(sum, 1.0, 1e-12) << q << " " << zp << " " << place;
      }
    }
  }
}

TEST_F(Fabmap, PosteriorSumsToOneAndPicksTheRightPlace) {
  const std::vector<WordSet> samples(training_.begin(), training_.begin() + 200);
  FabMap fabmap(model_, samples);
  const WordSet a{0, 1, 2, 3, 9};
  const WordSet b{8, 10};
  const WordSet c{11};
  fabmap.addPlace(a);
  fabmap.addPlace(b);
  fabmap.addPlace(c);
  const auto revisit = fabmap.posterior(a);
  ASSERT_EQ(revisit.size(), 4U);
  EXPECT_NEAR(std::accumulate(revisit.begin(), revisit.end(), 0.0), 1.0, 1e-12);
  EXPECT_EQ(std::max_element(revisit.begin(), revisit.end()) - revisit.begin(), 0);
  EXPECT_GT(revisit[0], 0.5);
  // A typical scene that shares no word with any mapped place: a new place.
  const auto unseen = fabmap.posterior({4, 5, 6, 7});
  EXPECT_EQ(std::max_element(unseen.begin(), unseen.end()) - unseen.begin(), 3);

  FabMap mean_field(model_, {}, NewPlaceMethod::kMeanField);
  mean_field.addPlace(a);
  const auto p = mean_field.posterior(a);
  EXPECT_NEAR(p[0] + p[1], 1.0, 1e-12);
  EXPECT_GT(p[0], p[1]);
}

TEST_F(Fabmap, Fabmap2GivesTheSamePosteriorsAsFabmap1) {
  const std::vector<WordSet> samples(training_.begin(), training_.begin() + 300);
  FabMap one(model_, samples);
  FabMap2 two(model_, samples);
  for (std::size_t k = 1000; k < 1100; ++k) {
    one.addPlace(training_[k]);
    two.addPlace(training_[k]);
  }
  EXPECT_EQ(two.places(), 100U);
  for (std::size_t k = 1500; k < 1520; ++k) {
    const auto p1 = one.posterior(training_[k]);
    const auto p2 = two.posterior(training_[k]);
    ASSERT_EQ(p1.size(), p2.size());
    for (std::size_t i = 0; i < p1.size(); ++i) ASSERT_NEAR(p1[i], p2[i], 1e-9) << k << " " << i;
  }
}

TEST_F(Fabmap, TheNewPlacePriorMakesUnfamiliarScansNewAndRevisitsNot) {
  const std::vector<WordSet> samples(training_.begin(), training_.begin() + 300);
  FabMap2 fabmap(model_, samples);
  for (std::size_t k = 1000; k < 1050; ++k) fabmap.addPlace(training_[k]);
  std::vector<bool> all(fabmap.places(), true);
  const auto prior = placePrior(all, {}, model_.params());
  // Unlike every place: only rare words, none of the chain.
  const auto unfamiliar = fabmap.posterior({9, 10, 11}, prior);
  EXPECT_GT(unfamiliar.back(), 0.5);
  EXPECT_GT(unfamiliar.back(), 5 * fabmap.posterior({9, 10, 11}).back())
      << "a uniform prior gives new only 1 / (places + 1) of it";
  // A revisit of a distinctive place (two rare words).
  const WordSet distinctive{0, 1, 2, 3, 4, 9, 10};
  fabmap.addPlace(distinctive);
  all.push_back(true);
  const auto known = fabmap.posterior(distinctive, placePrior(all, {}, model_.params()));
  EXPECT_LT(known.back(), 0.2);
  EXPECT_GT(known[fabmap.places() - 1], 0.5);
  EXPECT_NEAR(std::accumulate(known.begin(), known.end(), 0.0), 1.0, 1e-12);
}

TEST_F(Fabmap, ExcludedPlacesCarryNoMass) {
  const std::vector<WordSet> samples(training_.begin(), training_.begin() + 300);
  FabMap2 fabmap(model_, samples);
  fabmap.addPlace({0, 1, 2, 3, 9});
  fabmap.addPlace({8, 10});
  fabmap.addPlace({11});
  const auto prior = placePrior({true, false, true}, {}, model_.params());
  EXPECT_EQ(prior[1], 0.0);
  const auto p = fabmap.posterior({8, 10}, prior);  // place 1's own words
  EXPECT_EQ(p[1], 0.0) << "not even the smoothing's share";
  EXPECT_NEAR(p[0] + p[2] + p[3], 1.0, 1e-12);
  EXPECT_THROW(fabmap.posterior({8, 10}, {0.5, 0.5}), std::invalid_argument);
}

TEST(PlacePrior, SumsToOneAndFollowsThePreviousQueryForward) {
  FabMapParams params;
  const std::vector<bool> all(10, true);
  const auto uniform = placePrior(all, {}, params);
  ASSERT_EQ(uniform.size(), 11U);
  EXPECT_DOUBLE_EQ(uniform.back(), 0.9);
  EXPECT_NEAR(uniform[3], 0.01, 1e-15);
  // The query before was at place 4 (over 9 places then: 10 entries).
  std::vector<double> previous(10, 0.0);
  previous[4] = 0.8;
  previous.back() = 0.2;
  const auto moved = placePrior(all, previous, params);
  EXPECT_NEAR(std::accumulate(moved.begin(), moved.end(), 0.0), 1.0, 1e-12);
  EXPECT_EQ(std::max_element(moved.begin(), moved.end() - 1) - moved.begin(), 5) << "forward";
  EXPECT_NEAR(moved[4], moved[3], 1e-15);
  EXPECT_GT(moved[4], moved[0]);
  // What cannot be matched gets nothing, and the rest still sums to one.
  std::vector<bool> some = all;
  some[5] = some[6] = false;
  const auto gated = placePrior(some, previous, params);
  EXPECT_EQ(gated[5], 0.0);
  EXPECT_NEAR(std::accumulate(gated.begin(), gated.end(), 0.0), 1.0, 1e-12);
  // Sure the query before was new: uniform again.
  std::vector<double> was_new(10, 0.0);
  was_new.back() = 1.0;
  EXPECT_EQ(placePrior(all, was_new, params), uniform);
  // No place may be matched: new for sure.
  EXPECT_EQ(placePrior({false, false}, {}, params), (std::vector<double>{0.0, 0.0, 1.0}));
}

TEST(Vocabulary, KMeansFindsBlobsQuantizesAndRoundTrips) {
  std::mt19937 rng(4);
  std::normal_distribution<float> noise(0.0F, 0.001F);
  std::vector<features::SpinImage> centres(5);
  for (std::size_t c = 0; c < centres.size(); ++c) {
    centres[c].fill(0.0F);
    centres[c][c * 20] = 1.0F;  // far apart
  }
  std::vector<features::SpinImage> descriptors;
  for (int k = 0; k < 200; ++k) {
    features::SpinImage d = centres[static_cast<std::size_t>(k % 5)];
    for (float& v : d) v += noise(rng);
    descriptors.push_back(d);
  }
  const Vocabulary vocabulary = Vocabulary::train(descriptors, 5, 1);
  ASSERT_EQ(vocabulary.size(), 5U);
  // Each blob maps to one word, different blobs to different words.
  std::set<std::uint32_t> words;
  for (const auto& centre : centres) {
    const WordSet set = vocabulary.quantize({centre});
    ASSERT_EQ(set.size(), 1U);
    words.insert(set.front());
  }
  EXPECT_EQ(words.size(), 5U);
  EXPECT_TRUE(vocabulary.quantize({centres[0]}, 1e-6).size() <= 1U);
  EXPECT_TRUE(vocabulary.quantize(descriptors, 0.0).empty());  // nothing within distance 0

  const auto path =
      std::filesystem::temp_directory_path() / ("ccir_vocabulary_" + std::to_string(::getpid()));
  vocabulary.save(path.string());
  const Vocabulary loaded = Vocabulary::load(path.string());
  EXPECT_EQ(loaded.hash(), vocabulary.hash());
  EXPECT_EQ(loaded.quantize(descriptors), vocabulary.quantize(descriptors));
  {
    std::fstream corrupt(path, std::ios::in | std::ios::out | std::ios::binary);
    corrupt.seekp(-8, std::ios::end);
    corrupt.write("\x7f\x7f\x7f\x7f", 4);
  }
  EXPECT_THROW(Vocabulary::load(path.string()), std::runtime_error);  // hash mismatch
  // Regression (fuzz_vocabulary): a header announcing millions of words is refused, not
  // allocated.
  std::ofstream(path, std::ios::binary) << "ccir_mapping vocabulary 1 3794782 0123\n"
                                        << "words";
  try {
    Vocabulary::load(path.string());
    ADD_FAILURE() << "a vocabulary of 3794782 words in 5 bytes was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Vocabulary::load("/nonexistent"), std::runtime_error);
  EXPECT_THROW(Vocabulary::train(descriptors, 500), std::invalid_argument);

  const ChowLiuTree tree = ChowLiuTree::learn({{0, 1}, {1, 2}, {0, 2, 3}}, 5);
  tree.save(path.string(), vocabulary.hash());
  EXPECT_EQ(ChowLiuTree::load(path.string(), vocabulary.hash(), 5).size(), 5U);
  EXPECT_THROW(ChowLiuTree::load(path.string(), "another", 5), std::runtime_error);
  // Regressions (fuzz_place_model): a tree of another size than its vocabulary, and a probability
  // of 0 or beyond 1, which made FAB-MAP's log-likelihoods infinite, are refused at load.
  EXPECT_THROW(ChowLiuTree::load(path.string(), vocabulary.hash(), 500), std::runtime_error);
  std::ofstream(path) << "ccir_mapping chow_liu_tree 1 2 " << vocabulary.hash()
                      << "\n0 0.5 0.5 0.5\n0 0 745 0.99\n";
  try {
    ChowLiuTree::load(path.string(), vocabulary.hash(), 2);
    ADD_FAILURE() << "a marginal of 0 was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad entry for word 1"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

TEST(HistogramMatcher, VotesForTheKeyframeSharingDescriptors) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  auto random_descriptors = [&](int n) {
    std::vector<features::SpinImage> d(static_cast<std::size_t>(n));
    for (auto& x : d) {
      for (float& v : x) v = u(rng);
    }
    return d;
  };
  HistogramMatcher matcher(HistogramParams{});
  const auto revisited = random_descriptors(30);
  matcher.addKeyframe(7, random_descriptors(30));
  matcher.addKeyframe(8, revisited);
  matcher.addKeyframe(9, random_descriptors(30));
  EXPECT_EQ(matcher.keyframes(), 3U);
  // The query: 20 of keyframe 8's descriptors (slightly perturbed) and 10 new ones.
  auto query = random_descriptors(10);
  for (int i = 0; i < 20; ++i) {
    auto d = revisited[static_cast<std::size_t>(i)];
    for (float& v : d) v += 0.001F * u(rng);
    query.push_back(d);
  }
  const auto candidates = matcher.candidates(query);
  ASSERT_FALSE(candidates.empty());
  EXPECT_EQ(candidates.front().keyframe, 8U);
  EXPECT_GE(candidates.front().votes, 20);
  for (std::size_t i = 1; i < candidates.size(); ++i) {
    EXPECT_LT(candidates[i].votes, candidates.front().votes);
  }
  HistogramParams strict;
  strict.max_distance = 0.01;
  HistogramMatcher close(strict);
  close.addKeyframe(8, revisited);
  close.addKeyframe(9, random_descriptors(30));
  const auto only = close.candidates(query);
  ASSERT_EQ(only.size(), 1U);
  EXPECT_EQ(only.front().votes, 20);
  EXPECT_TRUE(HistogramMatcher(HistogramParams{}).candidates(query).empty());
}

/// A scan from the middle of a 30 x 30 m room (walls 4 m high) cluttered with boxes of
/// random size and height, all placed from `seed`; the sensor at 1 m.
pcl::PointCloud<pcl::PointXYZ> clutteredRoom(unsigned seed, double yaw_deg = 0.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> where(-12.0, 12.0), size(0.5, 3.0), height(0.3, 3.5);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  const auto add = [&](double x, double y, double top) {
    for (double z = -1.0; z <= top - 1.0; z += 0.25) cloud.push_back(pcl::PointXYZ(x, y, z));
  };
  for (double t = -15.0; t <= 15.0; t += 0.2) {
    for (const auto& [x, y] : {std::pair{t, -15.0}, {t, 15.0}, {-15.0, t}, {15.0, t}}) {
      add(x, y, 4.0);
    }
  }
  for (int box = 0; box < 12; ++box) {
    const double cx = where(rng), cy = where(rng), half = size(rng) / 2, top = height(rng);
    if (std::hypot(cx, cy) < 3.0) continue;
    for (double t = -half; t <= half; t += 0.1) {
      for (const auto& [x, y] : {std::pair{cx + t, cy - half},
                                 {cx + t, cy + half},
                                 {cx - half, cy + t},
                                 {cx + half, cy + t}}) {
        add(x, y, top);
      }
    }
  }
  const Eigen::Matrix3f turn =
      Eigen::AngleAxisf(static_cast<float>(yaw_deg * M_PI / 180), Eigen::Vector3f::UnitZ())
          .toRotationMatrix();
  for (auto& p : cloud) p.getVector3fMap() = turn * p.getVector3fMap();
  return cloud;
}

TEST(ScanContext, AYawedCopyMatchesAtTheRightShift) {
  ScanContextParams params;
  const ScanContext place(clutteredRoom(1), params);
  EXPECT_EQ(place.descriptor().rows(), 20);
  EXPECT_EQ(place.descriptor().cols(), 60);
  EXPECT_GT(place.ringKey().maxCoeff(), 0.5F);
  // The same place seen with the sensor turned by -30 degrees: directions 30 degrees further
  // round (5 of the 60 sectors).
  const ScanContext turned(clutteredRoom(1, 30.0), params);
  const auto match = scanContextDistance(place, turned, params);
  EXPECT_LT(match.distance, 0.05);
  EXPECT_EQ(match.shift, 5);
  EXPECT_NEAR(match.yaw_rad, -30 * M_PI / 180, 1e-9);
  ScanContextParams coarse = params;
  coarse.sectors = 30;
  EXPECT_THROW(scanContextDistance(place, ScanContext(clutteredRoom(1), coarse), params),
               std::invalid_argument);
  const auto itself = scanContextDistance(place, place, params);
  EXPECT_NEAR(itself.distance, 0.0, 1e-6);
  EXPECT_EQ(itself.shift, 0);
}

TEST(ScanContext, ADifferentPlaceDoesNotMatchAndTheIndexFindsTheRightOne) {
  ScanContextParams params;
  ScanContextIndex index(params);
  for (unsigned seed = 1; seed <= 30; ++seed) index.add(ScanContext(clutteredRoom(seed), params));
  const ScanContext query(clutteredRoom(17, -102.0), params);
  const auto matches = index.query(query, [](std::size_t) { return true; });
  ASSERT_EQ(matches.size(), 10U) << "ring_key_candidates";
  EXPECT_EQ(matches[0].index, 16U);
  EXPECT_LT(matches[0].distance.distance, 0.05);
  EXPECT_GT(matches[1].distance.distance, 3 * matches[0].distance.distance + 0.05)
      << "another room";
  const auto without = index.query(query, [](std::size_t i) { return i != 16; });
  for (const auto& m : without) EXPECT_NE(m.index, 16U) << "not eligible";
  EXPECT_FALSE(ScanContextParams{}.validate().size());
  ScanContextParams bad;
  bad.sectors = 2;
  ASSERT_EQ(bad.validate().size(), 1U);
  EXPECT_NE(bad.validate()[0].find("scan_context_sectors"), std::string::npos);
}

TEST(ScanContext, TheRealRevisitIsNearerThanTheOtherPlace) {
  const char* env = std::getenv("CCIR_DATA_DIR");
  const std::filesystem::path lidar =
      std::filesystem::path(env ? env : CCIR_DEFAULT_DATA_DIR) / "lidar";
  if (!std::filesystem::exists(lidar / "16line_1.pcd")) {
    GTEST_SKIP() << "SKIPPED: real scans not found under " << lidar << " (set CCIR_DATA_DIR)";
  }
  const ScanContextParams params;
  auto load = [&](const char* name) {
    pcl::PointCloud<pcl::PointXYZ> scan;
    EXPECT_EQ(pcl::io::loadPCDFile((lidar / name).string(), scan), 0) << name;
    return ScanContext(scan, params);
  };
  const ScanContext first = load("16line_1.pcd");
  const auto revisit = scanContextDistance(first, load("16line_2.pcd"), params);
  const auto other = scanContextDistance(first, load("16line_other.pcd"), params);
  std::printf("revisit %.3f (yaw %.0f deg), other place %.3f\n", revisit.distance,
              revisit.yaw_rad * 180 / M_PI, other.distance);
  EXPECT_LT(revisit.distance, other.distance);
  // The verification finds the revisit turned by ~11 degrees: two 6-degree sectors.
  EXPECT_NEAR(std::abs(revisit.yaw_rad) * 180 / M_PI, 11.0, 6.0);
}

}  // namespace
}  // namespace ccir_mapping::core::place_recognition
