// bench_preprocess: milliseconds per scan for preprocessing (crop, voxel grid, normals,
// degenerate-normal filter) and per keyframe for features (ISS + spin images) on one core, on a
// real scan (PCD). Prints JSON. Targets on the 16-line VLP-16 scans: <= 20 ms/scan and
// <= 100 ms/keyframe.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <vector>

#include <pcl/io/pcd_io.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
using ccir_mapping::core::features::ExtractionStats;
using ccir_mapping::core::features::FeatureExtractor;
using ccir_mapping::core::features::FeatureParams;
using ccir_mapping::core::preprocess::PreprocessorParams;
using ccir_mapping::core::preprocess::PreprocessStats;
using ccir_mapping::core::preprocess::ScanPreprocessor;

namespace {

struct Timing {
  double median_ms;
  double p90_ms;
};

template <class F>
Timing measure(int repeats, F&& run) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    run();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms[std::min(ms.size() - 1, ms.size() * 9 / 10)]};
}

struct Options {
  std::string pcd;
  int repeats = 20;
  PreprocessorParams preprocess;
  FeatureParams features;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  std::string drop_horizontal = "both";  // in the features
  po::options_description options(
      "Usage: bench_preprocess --pcd FILE [--repeats N]\n"
      "Prints JSON: median and p90 ms per scan (preprocessing) and per keyframe (ISS + spin\n"
      "images) with the default parameters, one thread.\n\nOptions");
  options.add_options()("help,h", "print this help and exit")(
      "pcd", po::value<std::string>(&o->pcd), "scan in the sensor frame (x y z [intensity])")(
      "repeats", po::value<int>(&o->repeats)->default_value(o->repeats), "runs of each stage")(
      "voxel-leaf-m",
      po::value<double>(&o->preprocess.voxel_leaf_m)->default_value(o->preprocess.voxel_leaf_m),
      "preprocessing voxel edge")("normal-radius-m",
                                  po::value<double>(&o->preprocess.normal_radius_m)
                                      ->default_value(o->preprocess.normal_radius_m),
                                  "normal estimation radius")(
      "drop-horizontal", po::value<std::string>(&drop_horizontal)->default_value(drop_horizontal),
      "degenerate-normal filter of the features: none | ground | ceiling | both")(
      "feature-voxel-m",
      po::value<double>(&o->features.voxel_m)->default_value(o->features.voxel_m),
      "feature voxel edge");
  if (const auto exit_code = tools::parseCommandLine("bench_preprocess", options, argc, argv)) {
    return exit_code;
  }
  if (o->pcd.empty() || o->repeats < 1) {
    return tools::usageError("bench_preprocess",
                             "--pcd FILE is required and --repeats must be >= 1");
  }
  const auto filter = ccir_mapping::core::preprocess::parseHorizontalFilter(drop_horizontal);
  if (!filter) {
    return tools::usageError("bench_preprocess",
                             "--drop-horizontal must be none | ground | ceiling | both");
  }
  o->features.drop_horizontal = *filter;
  return std::nullopt;
}

struct Results {
  Timing preprocessing, features;
  PreprocessStats preprocess_stats;
  ExtractionStats feature_stats;
};

Results run(const Options& o, const pcl::PointCloud<pcl::PointXYZI>& scan) {
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const ScanPreprocessor preprocessor{o.preprocess};
  Results r;
  ScanPreprocessor::OutputCloud::Ptr keyframe;
  r.preprocessing =
      measure(o.repeats, [&] { keyframe = preprocessor.process(scan, up, &r.preprocess_stats); });
  const FeatureExtractor extractor{o.features};
  r.features = measure(o.repeats, [&] { extractor.extract(*keyframe, up, &r.feature_stats); });
  return r;
}

void report(const Options& o, const Results& r) {
  const PreprocessStats& pre = r.preprocess_stats;
  const ExtractionStats& feat = r.feature_stats;
  std::printf(
      "{\n  \"benchmark\": \"preprocess\",\n  \"pcd\": \"%s\",\n  \"threads\": 1,\n"
      "  \"repeats\": %d,\n"
      "  \"preprocessing\": {\"median_ms\": %.1f, \"p90_ms\": %.1f, \"target_ms\": 20, "
      "\"points_in\": %zu, \"voxels\": %zu, \"horizontal_dropped\": %zu, \"points_out\": %zu},\n"
      "  \"features\": {\"median_ms\": %.1f, \"p90_ms\": %.1f, \"target_ms\": 100, "
      "\"points\": %zu, \"keypoints\": %zu, \"descriptors\": %zu}\n}\n",
      o.pcd.c_str(), o.repeats, r.preprocessing.median_ms, r.preprocessing.p90_ms, pre.points_in,
      pre.voxels, pre.horizontal, pre.points_out, r.features.median_ms, r.features.p90_ms,
      feat.points, feat.keypoints, feat.descriptors);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  pcl::PointCloud<pcl::PointXYZI> scan;
  if (pcl::io::loadPCDFile(options.pcd, scan) != 0 || scan.empty()) {
    std::cerr << "bench_preprocess: cannot read a cloud from " << options.pcd << '\n';
    return 1;
  }
  report(options, run(options, scan));
  return 0;
}
