// bench_hgmm: hierarchical Gaussian mixtures of keyframe clouds on one core. For each scan
// (PCD, preprocessed as the pipeline does): the time to fit the hierarchy, and per level its
// components, wire bytes, compression against the cloud as x y z float32, the mean
// log-likelihood of the cloud's points, and how well as many points sampled from it rebuild the
// cloud: Chamfer distance, and precision / recall of the occupied voxels at --voxel-m (the
// cells an OctoMap of the points at that resolution marks occupied). Prints JSON. With
// --samples-out DIR also writes each scan's points and each level's samples as "x y z" lines
// (DIR/<scan>_points.xyz, DIR/<scan>_level<L>.xyz) for ccir_mapping.plot_hgmm. Each scan after
// the first is also registered onto the first from the identity, by its deepest level's
// mixture (GMM-to-GMM GICP) and by points sampled from it (GICP onto the first's points). The
// voxel comparison's own floor is printed too: the scan against itself remeasured with 1-3 cm
// of range noise.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include <pcl/io/pcd_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/hgmm/hgmm.h"
#include "ccir_mapping/core/hgmm/mixture_registration.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace hgmm = core::hgmm;
namespace tools = ccir_mapping::tools;

namespace {

struct Options {
  std::vector<std::string> pcds;
  double voxel_m = 0.1;
  std::string samples_out;
  hgmm::HgmmParams params;
};

std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: bench_hgmm --pcd FILE [FILE ...] [options]\nPrints JSON.\n\nOptions", 100);
  options.add_options()("help,h", "print this help and exit")(
      "pcd", po::value<std::vector<std::string>>(&o->pcds)->multitoken(), "scans (x y z ...)")(
      "voxel-m", po::value<double>(&o->voxel_m)->default_value(o->voxel_m),
      "voxel edge of the occupancy comparison [m]")(
      "samples-out", po::value<std::string>(&o->samples_out),
      "directory for the points and samples as text (for plotting)")(
      "components",
      po::value<int>(&o->params.em.components)->default_value(o->params.em.components),
      "Gaussians per EM fit (the root's and each split's)")(
      "max-depth", po::value<int>(&o->params.max_depth)->default_value(o->params.max_depth),
      "levels below the root")(
      "min-points-to-split",
      po::value<int>(&o->params.min_points_to_split)->default_value(o->params.min_points_to_split),
      "a node with fewer points is not split");
  if (const auto exit_code = tools::parseCommandLine("bench_hgmm", options, argc, argv)) {
    return exit_code;
  }
  const auto errors = o->params.validate();
  if (o->pcds.empty() || !errors.empty() || !(o->voxel_m > 0)) {
    return tools::usageError("bench_hgmm",
                             errors.empty() ? "need --pcd and --voxel-m > 0" : errors.front());
  }
  return std::nullopt;
}

struct Level {
  std::size_t components = 0, bytes = 0;
  double log_likelihood = 0.0, chamfer_m = 0.0, precision = 0.0, recall = 0.0;
};

struct Aligned {
  bool accepted = false;
  double ms = 0.0, yaw_deg = 0.0, shift_m = 0.0, fitness_m2 = 0.0;
};

struct Scan {
  std::string file;
  std::size_t points = 0;
  double fit_ms = 0.0;
  std::vector<Level> levels;
  /// The metric's own floor: the scan's points moved along their beams by Gaussian range noise
  /// of each of kRangeNoisesM, as a second measurement of the same scene would be.
  std::vector<std::pair<double, double>> remeasured;  // precision, recall
  std::optional<Aligned> mixtures, sampled;           // onto the first scan
};

constexpr double kRangeNoisesM[] = {0.01, 0.02, 0.03};

template <class F>
Aligned timed(F&& run) {
  const auto start = std::chrono::steady_clock::now();
  const hgmm::Registration r = run();
  Aligned a;
  a.ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  a.accepted = r.accepted;
  a.fitness_m2 = r.fitness_m2;
  a.yaw_deg = std::atan2(r.transform(1, 0), r.transform(0, 0)) * 180 / M_PI;
  a.shift_m = r.transform.translation().norm();
  return a;
}

using Voxel = std::tuple<long, long, long>;

void writeXyz(const std::filesystem::path& file, const hgmm::Points& points) {
  std::ofstream out(file);
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    out << points(0, i) << ' ' << points(1, i) << ' ' << points(2, i) << '\n';
  }
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

std::set<Voxel> voxels(const hgmm::Points& points, double edge) {
  std::set<Voxel> out;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Eigen::Vector3d v = (points.col(i) / edge).array().floor();
    out.emplace(long(v.x()), long(v.y()), long(v.z()));
  }
  return out;
}

/// Mean distance from each point of `from` to the nearest of `to`.
double meanNearest(const hgmm::Points& from, const hgmm::Points& to) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (Eigen::Index i = 0; i < to.cols(); ++i) {
    cloud->push_back(pcl::PointXYZ(float(to(0, i)), float(to(1, i)), float(to(2, i))));
  }
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  pcl::Indices index(1);
  std::vector<float> d2(1);
  double sum = 0.0;
  for (Eigen::Index i = 0; i < from.cols(); ++i) {
    tree.nearestKSearch(pcl::PointXYZ(float(from(0, i)), float(from(1, i)), float(from(2, i))), 1,
                        index, d2);
    sum += std::sqrt(d2[0]);
  }
  return sum / double(std::max<Eigen::Index>(1, from.cols()));
}

std::vector<Scan> run(const Options& o) {
  const core::preprocess::ScanPreprocessor preprocessor{core::preprocess::PreprocessorParams{}};
  std::vector<Scan> scans;
  std::optional<std::pair<hgmm::Hgmm, hgmm::Points>> first;
  for (const std::string& file : o.pcds) {
    pcl::PointCloud<pcl::PointXYZI> raw;
    if (pcl::io::loadPCDFile(file, raw) != 0) throw std::runtime_error("cannot read " + file);
    const auto cloud = preprocessor.process(raw, Eigen::Vector3f::UnitZ());
    hgmm::Points points(3, Eigen::Index(cloud->size()));
    for (std::size_t i = 0; i < cloud->size(); ++i) {
      points.col(Eigen::Index(i)) = (*cloud)[i].getVector3fMap().cast<double>();
    }
    Scan scan;
    scan.file = file;
    scan.points = cloud->size();
    const auto start = std::chrono::steady_clock::now();
    const hgmm::Hgmm model = hgmm::Hgmm::build(points, o.params);
    scan.fit_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const std::set<Voxel> occupied = voxels(points, o.voxel_m);
    const std::filesystem::path out_stem =
        o.samples_out.empty()
            ? std::filesystem::path()
            : std::filesystem::path(o.samples_out) / std::filesystem::path(file).stem();
    if (!o.samples_out.empty()) {
      std::filesystem::create_directories(o.samples_out);
      writeXyz(out_stem.string() + "_points.xyz", points);
    }
    std::mt19937_64 rng(1);
    for (int l = 0; l <= model.depth(); ++l) {
      const hgmm::GaussianMixture mixture = model.level(l);
      const hgmm::Points samples = mixture.sample(std::size_t(points.cols()), rng);
      const std::set<Voxel> rebuilt = voxels(samples, o.voxel_m);
      if (!o.samples_out.empty()) {
        writeXyz(out_stem.string() + "_level" + std::to_string(l) + ".xyz", samples);
      }
      std::size_t common = 0;
      for (const Voxel& v : rebuilt) common += occupied.count(v);
      Level level;
      level.components = mixture.size();
      level.bytes = model.bytes(l);
      level.log_likelihood = mixture.meanLogLikelihood(points);
      level.chamfer_m = 0.5 * (meanNearest(points, samples) + meanNearest(samples, points));
      level.precision = double(common) / double(rebuilt.size());
      level.recall = double(common) / double(occupied.size());
      scan.levels.push_back(level);
    }
    for (const double noise_m : kRangeNoisesM) {
      std::normal_distribution<double> range_noise(0.0, noise_m);
      hgmm::Points moved = points;
      for (Eigen::Index i = 0; i < moved.cols(); ++i) {
        moved.col(i) += range_noise(rng) * moved.col(i).normalized();
      }
      const std::set<Voxel> rebuilt = voxels(moved, o.voxel_m);
      std::size_t common = 0;
      for (const Voxel& v : rebuilt) common += occupied.count(v);
      scan.remeasured.emplace_back(double(common) / double(rebuilt.size()),
                                   double(common) / double(occupied.size()));
    }
    if (first) {
      const hgmm::RegistrationParams registration;
      const auto& [target, target_points] = *first;
      const hgmm::GaussianMixture source = model.level(model.depth());
      scan.mixtures = timed([&] {
        return hgmm::registerMixtures(source, target.level(target.depth()), core::Pose3::Identity(),
                                      registration);
      });
      scan.sampled = timed([&] {
        return hgmm::registerSampled(source, target_points, core::Pose3::Identity(), registration,
                                     rng);
      });
    } else {
      first.emplace(model, points);
    }
    scans.push_back(std::move(scan));
  }
  return scans;
}

void report(const Options& o, const std::vector<Scan>& scans) {
  std::printf(
      "{\n  \"benchmark\": \"hgmm\",\n  \"components_per_fit\": %d,\n  \"max_depth\": %d,\n"
      "  \"voxel_m\": %g,\n  \"raw_bytes_per_point\": 12,\n  \"scans\": [\n",
      o.params.em.components, o.params.max_depth, o.voxel_m);
  for (std::size_t s = 0; s < scans.size(); ++s) {
    const Scan& scan = scans[s];
    std::printf("    {\"file\": \"%s\", \"points\": %zu, \"fit_ms\": %.1f, \"levels\": [\n",
                scan.file.c_str(), scan.points, scan.fit_ms);
    for (std::size_t l = 0; l < scan.levels.size(); ++l) {
      const Level& v = scan.levels[l];
      std::printf(
          "      {\"level\": %zu, \"components\": %zu, \"bytes\": %zu, \"compression\": %.1f, "
          "\"log_likelihood\": %.3f, \"chamfer_m\": %.3f, \"occupied_precision\": %.3f, "
          "\"occupied_recall\": %.3f}%s\n",
          l, v.components, v.bytes, 12.0 * double(scan.points) / double(v.bytes), v.log_likelihood,
          v.chamfer_m, v.precision, v.recall, l + 1 < scan.levels.size() ? "," : "");
    }
    std::printf("    ],\n     \"remeasured_with_range_noise\": [");
    for (std::size_t i = 0; i < scan.remeasured.size(); ++i) {
      std::printf(
          "%s{\"range_noise_m\": %g, \"occupied_precision\": %.3f, "
          "\"occupied_recall\": %.3f}",
          i ? ", " : "", kRangeNoisesM[i], scan.remeasured[i].first, scan.remeasured[i].second);
    }
    std::printf("]");
    for (const auto& [name, a] : {std::pair{"onto_first_by_mixtures", &scan.mixtures},
                                  std::pair{"onto_first_by_samples", &scan.sampled}}) {
      if (!*a) continue;
      std::printf(
          ",\n     \"%s\": {\"accepted\": %s, \"ms\": %.1f, \"yaw_deg\": %.2f, "
          "\"shift_m\": %.3f, \"fitness_m2\": %.3f}",
          name, (*a)->accepted ? "true" : "false", (*a)->ms, (*a)->yaw_deg, (*a)->shift_m,
          (*a)->fitness_m2);
    }
    std::printf("}%s\n", s + 1 < scans.size() ? "," : "");
  }
  std::printf("  ]\n}\n");
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("bench_hgmm", argc, argv, parse, run, report);
}
