// bench_preprocess: milliseconds per scan for preprocessing (crop, voxel grid, normals,
// degenerate-normal filter) and per keyframe for features (ISS + spin images) on one core, on a
// real scan (PCD). Prints JSON. Targets on the 16-line VLP-16 scans: <= 20 ms/scan and
// <= 100 ms/keyframe.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <vector>

#include <pcl/io/pcd_io.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"

namespace po = boost::program_options;
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

}  // namespace

int main(int argc, char** argv) {
  std::string pcd;
  int repeats = 20;
  PreprocessorParams pre_params;
  FeatureParams feature_params;
  std::string drop_horizontal = "both";  // in the features
  po::options_description options(
      "Usage: bench_preprocess --pcd FILE [--repeats N]\n"
      "Prints JSON: median and p90 ms per scan (preprocessing) and per keyframe (ISS + spin\n"
      "images) with the default parameters, one thread.\n\nOptions");
  options.add_options()("help,h", "print this help and exit")(
      "pcd", po::value<std::string>(&pcd), "scan in the sensor frame (x y z [intensity])")(
      "repeats", po::value<int>(&repeats)->default_value(repeats), "runs of each stage")(
      "voxel-leaf-m",
      po::value<double>(&pre_params.voxel_leaf_m)->default_value(pre_params.voxel_leaf_m),
      "preprocessing voxel edge")(
      "normal-radius-m",
      po::value<double>(&pre_params.normal_radius_m)->default_value(pre_params.normal_radius_m),
      "normal estimation radius")(
      "drop-horizontal", po::value<std::string>(&drop_horizontal)->default_value(drop_horizontal),
      "degenerate-normal filter of the features: none | ground | ceiling | both")(
      "feature-voxel-m",
      po::value<double>(&feature_params.voxel_m)->default_value(feature_params.voxel_m),
      "feature voxel edge");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "bench_preprocess: " << e.what() << '\n';
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  if (pcd.empty() || repeats < 1) {
    std::cerr << "bench_preprocess: --pcd FILE is required and --repeats must be >= 1\n";
    return 2;
  }
  pcl::PointCloud<pcl::PointXYZI> scan;
  if (pcl::io::loadPCDFile(pcd, scan) != 0 || scan.empty()) {
    std::cerr << "bench_preprocess: cannot read a cloud from " << pcd << '\n';
    return 1;
  }

  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const auto filter = ccir_mapping::core::preprocess::parseHorizontalFilter(drop_horizontal);
  if (!filter) {
    std::cerr << "bench_preprocess: --drop-horizontal must be none | ground | ceiling | both\n";
    return 2;
  }
  feature_params.drop_horizontal = *filter;
  const ScanPreprocessor preprocessor{pre_params};
  PreprocessStats pre;
  ScanPreprocessor::OutputCloud::Ptr keyframe;
  const Timing preprocessing =
      measure(repeats, [&] { keyframe = preprocessor.process(scan, up, &pre); });
  const FeatureExtractor extractor{feature_params};
  ExtractionStats feat;
  const Timing features = measure(repeats, [&] { extractor.extract(*keyframe, up, &feat); });

  std::printf(
      "{\n  \"benchmark\": \"preprocess\",\n  \"pcd\": \"%s\",\n  \"threads\": 1,\n"
      "  \"repeats\": %d,\n"
      "  \"preprocessing\": {\"median_ms\": %.1f, \"p90_ms\": %.1f, \"target_ms\": 20, "
      "\"points_in\": %zu, \"voxels\": %zu, \"horizontal_dropped\": %zu, \"points_out\": %zu},\n"
      "  \"features\": {\"median_ms\": %.1f, \"p90_ms\": %.1f, \"target_ms\": 100, "
      "\"points\": %zu, \"keypoints\": %zu, \"descriptors\": %zu}\n}\n",
      pcd.c_str(), repeats, preprocessing.median_ms, preprocessing.p90_ms, pre.points_in,
      pre.voxels, pre.horizontal, pre.points_out, features.median_ms, features.p90_ms, feat.points,
      feat.keypoints, feat.descriptors);
  return 0;
}
