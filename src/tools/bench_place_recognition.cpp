// bench_place_recognition: milliseconds of a FAB-MAP query over 1000 mapped places (2.0 with its
// inverted index, and 1.0 for comparison, same posteriors) on synthetic word sets, and of the
// geometric verification of one candidate on the real 16-line revisit pair, and of a Scan
// Context query over as many places (random clouds: the cost does not depend on what they
// show), and of the Matcher's hgmm query against 500 stored keyframes (copies of the real
// 16-line scans, so that every candidate registers and is verified: the worst case). Prints
// JSON. Targets: FAB-MAP query <= 10 ms, verification <= 150 ms per candidate, Scan Context
// query <= 5 ms, hgmm query <= 200 ms.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <random>

#include <pcl/io/pcd_io.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/place_recognition/fabmap.h"
#include "ccir_mapping/core/place_recognition/place_matcher.h"
#include "ccir_mapping/core/place_recognition/scan_context_index.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/core/registration/scan_verifier.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace pr = ccir_mapping::core::place_recognition;
namespace core = ccir_mapping::core;
namespace tools = ccir_mapping::tools;

namespace {

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// Word sets where each keyframe shows ~words_per_set of `words` words, in correlated groups
/// (neighbouring ids tend to fire together, as features of one structure do).
std::vector<pr::WordSet> wordSets(int count, int words, int words_per_set, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> start(0, words - 8);
  std::bernoulli_distribution keep(0.7);
  std::vector<pr::WordSet> sets;
  for (int k = 0; k < count; ++k) {
    pr::WordSet set;
    while (static_cast<int>(set.size()) < words_per_set) {
      const int group = start(rng);
      for (int w = group; w < group + 8; ++w) {
        if (keep(rng)) set.push_back(static_cast<std::uint32_t>(w));
      }
      std::sort(set.begin(), set.end());
      set.erase(std::unique(set.begin(), set.end()), set.end());
    }
    sets.push_back(set);
  }
  return sets;
}

struct Options {
  int places = 1000;
  int hgmm_places = 500;
  int words = 2000;
  std::string data = std::getenv("CCIR_DATA_DIR") ? std::getenv("CCIR_DATA_DIR") : "";
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: bench_place_recognition [--places N] [--words V] [--data DIR]\nPrints "
      "JSON.\n\nOptions");
  options.add_options()("help,h", "print this help and exit")(
      "places", po::value<int>(&o->places)->default_value(o->places), "mapped places")(
      "hgmm-places", po::value<int>(&o->hgmm_places)->default_value(o->hgmm_places),
      "stored keyframes of the hgmm query")(
      "words", po::value<int>(&o->words)->default_value(o->words), "vocabulary size")(
      "data", po::value<std::string>(&o->data), "shared data directory (default CCIR_DATA_DIR)");
  if (const auto exit_code =
          tools::parseCommandLine("bench_place_recognition", options, argc, argv)) {
    return exit_code;
  }
  if (o->places < 1 || o->hgmm_places < 1 || o->words < 16) {
    return tools::usageError("bench_place_recognition",
                             "--places, --hgmm-places >= 1 and --words >= 16");
  }
  return std::nullopt;
}

struct Results {
  double fabmap2_ms = 0, fabmap1_ms = 0, difference = 0;
  double verification_ms = -1.0;  // < 0: not measured (no real scans)
  /// Preparing a scan for verification from scratch, and completing a compacted one again
  /// (MatcherParams::complete_places), on the same real scan; its prepared points.
  double prepare_ms = -1.0, complete_again_ms = -1.0;
  std::size_t prepared_points = 0;
  /// Scan Context: building one descriptor (10 000 points), one query over the places.
  double scan_context_describe_ms = 0.0, scan_context_query_ms = 0.0;
  /// hgmm: describing a real scan (features, Scan Context, mixture) and one query; its
  /// candidates and the accepted ones.
  double hgmm_describe_ms = -1.0, hgmm_query_ms = -1.0;
  std::size_t hgmm_candidates = 0, hgmm_accepted = 0;
};

/// FAB-MAP 2.0 and 1.0 over the same places and queries; the posteriors are compared, so the
/// optimiser cannot drop the queries.
void measureFabMap(const Options& o, Results& r) {
  const auto training = wordSets(500, o.words, 150, 1);
  const pr::ChowLiuTree tree = pr::ChowLiuTree::learn(training, static_cast<std::size_t>(o.words));
  const pr::FabMapModel model(tree, pr::FabMapParams{});
  const std::vector<pr::WordSet> samples(training.begin(), training.begin() + 100);
  pr::FabMap one(model, samples);
  pr::FabMap2 two(model, samples);
  for (const auto& place : wordSets(o.places, o.words, 150, 2)) {
    one.addPlace(place);
    two.addPlace(place);
  }
  const auto queries = wordSets(20, o.words, 150, 3);
  std::vector<std::vector<double>> posteriors;
  auto start = std::chrono::steady_clock::now();
  for (const auto& q : queries) posteriors.push_back(two.posterior(q));
  r.fabmap2_ms = millisecondsSince(start) / queries.size();
  start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < 3; ++i) {
    const auto p = one.posterior(queries[i]);
    for (std::size_t j = 0; j < p.size(); ++j) {
      r.difference = std::max(r.difference, std::abs(p[j] - posteriors[i][j]));
    }
  }
  r.fabmap1_ms = millisecondsSince(start) / 3;
}

/// Scan Context over o.places random clouds of 10 000 points within 30 m.
void measureScanContext(const Options& o, Results& r) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> xy(-30.0F, 30.0F), z(-1.5F, 3.0F);
  const pr::ScanContextParams params;
  auto cloud = [&] {
    pcl::PointCloud<pcl::PointXYZ> c;
    for (int i = 0; i < 10000; ++i) c.push_back(pcl::PointXYZ(xy(rng), xy(rng), z(rng)));
    return c;
  };
  pr::ScanContextIndex index(params);
  double describe_ms = 0.0;
  for (int i = 0; i < o.places; ++i) {
    const auto c = cloud();
    const auto start = std::chrono::steady_clock::now();
    index.add(pr::ScanContext(c, params));
    describe_ms += millisecondsSince(start);
  }
  r.scan_context_describe_ms = describe_ms / o.places;
  std::vector<pr::ScanContext> queries;
  for (int i = 0; i < 20; ++i) queries.emplace_back(cloud(), params);
  std::size_t found = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& q : queries) found += index.query(q, [](std::size_t) { return true; }).size();
  r.scan_context_query_ms = millisecondsSince(start) / queries.size();
  if (found == 0) std::cerr << "bench_place_recognition: Scan Context found nothing\n";
}

/// A real 16-line scan of the shared data, preprocessed, or nullptr (with a message) when the
/// data is not there.
core::preprocess::ScanPreprocessor::OutputCloud::Ptr realScan(const Options& o, const char* name,
                                                              const char* measurement) {
  const std::filesystem::path lidar = std::filesystem::path(o.data) / "lidar";
  if (o.data.empty() || !std::filesystem::exists(lidar / name)) {
    std::cerr << "bench_place_recognition: no real scans under " << lidar
              << " (set CCIR_DATA_DIR): " << measurement << " not measured\n";
    return nullptr;
  }
  const core::preprocess::ScanPreprocessor preprocessor{core::preprocess::PreprocessorParams{}};
  pcl::PointCloud<pcl::PointXYZI> raw;
  pcl::io::loadPCDFile((lidar / name).string(), raw);
  return preprocessor.process(raw, Eigen::Vector3f::UnitZ());
}

/// The verification of the real 16-line revisit pair, when the data is there.
void measureVerification(const Options& o, Results& r) {
  core::features::FeatureParams feature_params;
  feature_params.drop_horizontal = core::preprocess::HorizontalFilter::kGround;
  const core::features::FeatureExtractor extractor(feature_params);
  auto load = [&](const char* name) {
    auto cloud = realScan(o, name, "verification");
    auto features = cloud ? extractor.extract(*cloud, Eigen::Vector3f::UnitZ())
                          : core::features::LocalFeatures{};
    return std::make_pair(cloud, features);
  };
  const auto a = load("16line_1.pcd");
  const auto b = load("16line_2.pcd");
  if (!a.first || !b.first) return;
  const core::registration::ScanVerifier verifier{core::registration::VerificationParams{}};
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 5; ++i) verifier.verify(*a.first, a.second, *b.first, b.second);
  r.verification_ms = millisecondsSince(start) / 5;

  auto prepare_start = std::chrono::steady_clock::now();
  core::registration::PreparedScan scan;
  for (int i = 0; i < 5; ++i) scan = verifier.prepare(*a.first, a.second);
  r.prepare_ms = millisecondsSince(prepare_start) / 5;
  r.prepared_points = scan.cloud->size();
  const auto again_start = std::chrono::steady_clock::now();
  for (int i = 0; i < 5; ++i) {
    core::registration::ScanVerifier::compact(scan);
    verifier.complete(scan);
  }
  r.complete_again_ms = millisecondsSince(again_start) / 5;
}

/// The Matcher's hgmm query (16line_2 as a teammate's scan) against o.hgmm_places stored
/// keyframes, each a copy of 16line_1, 16line_2 or 16line_other under its own id.
void measureHgmmQuery(const Options& o, Results& r) {
  const char* names[] = {"16line_1.pcd", "16line_2.pcd", "16line_other.pcd"};
  std::vector<core::preprocess::ScanPreprocessor::OutputCloud::Ptr> clouds;
  for (const char* name : names) {
    clouds.push_back(realScan(o, name, "the hgmm query"));
    if (!clouds.back()) return;
  }
  pr::MatcherParams params;
  params.method = pr::MatchMethod::kHgmm;
  params.search.prior_free_verifications_per_s = 0.0;  // one query's whole cost
  pr::PlaceMatcher matcher(params, pr::PlaceModel::load(CCIR_DEFAULT_MODEL_DIR));
  std::vector<pr::DescribedKeyframe> described;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& cloud : clouds) {
    described.push_back(matcher.describe(0, 0, *cloud, Eigen::Vector3f::UnitZ()));
  }
  r.hgmm_describe_ms = millisecondsSince(start) / clouds.size();
  // One stamp for all: within the loop-exclusion window, so storing them matches nothing.
  for (int i = 0; i < o.hgmm_places; ++i) {
    pr::DescribedKeyframe place = described[static_cast<std::size_t>(i) % described.size()];
    place.id = static_cast<core::KeyframeId>(i);
    matcher.addOwn(std::move(place));
  }
  pr::DescribedKeyframe query = described[1];
  query.id = 100000;
  const auto query_start = std::chrono::steady_clock::now();
  std::vector<pr::MatchCandidate> candidates;
  for (int i = 0; i < 3; ++i) candidates = matcher.matchTeammate("teammate", query);
  r.hgmm_query_ms = millisecondsSince(query_start) / 3;
  r.hgmm_candidates = candidates.size();
  r.hgmm_accepted = static_cast<std::size_t>(
      std::count_if(candidates.begin(), candidates.end(),
                    [](const pr::MatchCandidate& c) { return c.verification.accepted; }));
}

void report(const Options& o, const Results& r) {
  std::printf(
      "{\n  \"benchmark\": \"place_recognition\",\n  \"places\": %d,\n  \"words\": %d,\n"
      "  \"words_per_keyframe\": 150,\n  \"fabmap2_query_ms\": %.3f,\n"
      "  \"fabmap1_query_ms\": %.2f,\n  \"fabmap_target_ms\": 10,\n"
      "  \"fabmap1_vs_2_max_posterior_difference\": %.2g,\n  \"verification_ms\": %.1f,\n"
      "  \"verification_target_ms\": 150,\n  \"prepared_points\": %zu,\n"
      "  \"prepare_ms\": %.1f,\n  \"complete_again_ms\": %.1f,\n"
      "  \"scan_context_describe_ms\": %.2f,\n  \"scan_context_query_ms\": %.3f,\n"
      "  \"scan_context_target_ms\": 5,\n  \"hgmm_places\": %d,\n  \"hgmm_describe_ms\": %.1f,\n"
      "  \"hgmm_query_ms\": %.1f,\n  \"hgmm_query_candidates\": %zu,\n"
      "  \"hgmm_query_accepted\": %zu,\n  \"hgmm_query_target_ms\": 200\n}\n",
      o.places, o.words, r.fabmap2_ms, r.fabmap1_ms, r.difference, r.verification_ms,
      r.prepared_points, r.prepare_ms, r.complete_again_ms, r.scan_context_describe_ms,
      r.scan_context_query_ms, o.hgmm_places, r.hgmm_describe_ms, r.hgmm_query_ms,
      r.hgmm_candidates, r.hgmm_accepted);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  Results results;
  measureFabMap(options, results);
  measureScanContext(options, results);
  measureVerification(options, results);
  measureHgmmQuery(options, results);
  report(options, results);
  return 0;
}
