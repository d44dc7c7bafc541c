// pgo_benchmark: a g2o pose graph, optionally with injected false loop closures, optimised with
// a chosen robust treatment; prints JSON with the trajectory error (against ground truth, or
// against the outlier-free optimum), cost, iterations, time and loop classification.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/backend/g2o_io.h"
#include "ccir_mapping/core/backend/outlier_injector.h"
#include "ccir_mapping/core/backend/pose_graph_optimizer.h"
#include "ccir_mapping/core/backend/trajectory_error.h"
#include "mrpt_reference.h"

namespace po = boost::program_options;
namespace backend = ccir_mapping::core::backend;

namespace {

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  std::string g2o;
  std::string gt;
  std::string robust = "switchable";
  std::string switch_function = "linear";
  std::string outlier_mode = "random";
  backend::OutlierParams outliers;
  outliers.count = 0;
  int seed = 1;
  backend::OptimizerParams params;
  po::options_description options(
      "Usage: pgo_benchmark --g2o FILE [--gt FILE] [--outliers N] [--outlier-mode random|local|"
      "grouped]\n                     [--seed S] [--robust none|cauchy|huber|dcs|switchable] "
      "[--json]\nPrints JSON.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "g2o", po::value<std::string>(&g2o), "pose graph (VERTEX/EDGE_SE2 or _SE3:QUAT)")(
      "gt", po::value<std::string>(&gt),
      "ground-truth poses ([id] x y theta | [id] x y z qx qy qz qw); without it the error is "
      "against the outlier-free least-squares optimum")(
      "outliers", po::value<int>(&outliers.count)->default_value(0), "false loop closures to add")(
      "outlier-mode", po::value<std::string>(&outlier_mode)->default_value(outlier_mode),
      "random | local | grouped")(
      "group-size", po::value<int>(&outliers.group_size)->default_value(outliers.group_size),
      "edges per group (grouped)")("seed", po::value<int>(&seed)->default_value(seed),
                                   "outlier seed")(
      "robust", po::value<std::string>(&robust)->default_value(robust),
      "none | cauchy | huber | dcs | switchable")(
      "switch", po::value<std::string>(&switch_function)->default_value(switch_function),
      "switch function: linear | sigmoid")(
      "dcs-phi", po::value<double>(&params.dcs_phi)->default_value(params.dcs_phi),
      "DCS phi in chi^2 units; 0: auto (99 % quantile / 3)")(
      "switch-prior-sigma",
      po::value<double>(&params.switch_prior_sigma)->default_value(params.switch_prior_sigma),
      "switch prior sigma; 0: auto (1 / sqrt of the 99 % chi^2 quantile)")(
      "no-chain-start", "skip the first solve with chain-inflated loop covariances")(
      "max-iterations",
      po::value<int>(&params.max_iterations)->default_value(params.max_iterations),
      "solver iterations")(
      "threads", po::value<int>(&params.threads)->default_value(params.threads), "solver threads")(
      "reference", po::value<std::string>(),
      "mrpt: also run MRPT's optimiser on the outlier-free graph and compare time and cost")(
      "json", "print JSON (the only output format; accepted for scripts)");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "pgo_benchmark: " << e.what() << '\n';
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  const auto kernel = backend::parseRobustKernel(robust);
  const auto mode = backend::parseOutlierMode(outlier_mode);
  const std::string reference_solver =
      arguments.count("reference") ? arguments["reference"].as<std::string>() : "";
  if (!reference_solver.empty() && reference_solver != "mrpt") {
    std::cerr << "pgo_benchmark: --reference allows only mrpt\n";
    return 2;
  }
  if (g2o.empty() || !kernel || !mode || outliers.count < 0 ||
      (switch_function != "linear" && switch_function != "sigmoid")) {
    std::cerr << "pgo_benchmark: need --g2o FILE, --robust " << backend::kRobustKernelChoices
              << ", --outlier-mode " << backend::kOutlierModeChoices
              << ", --switch linear | sigmoid, --outliers >= 0 (see --help)\n";
    return 2;
  }
  outliers.mode = *mode;
  outliers.seed = static_cast<std::uint64_t>(seed);
  params.kernel = *kernel;
  params.uncertainty_aware_start = arguments.count("no-chain-start") == 0;
  params.switch_function = switch_function == "linear" ? backend::SwitchFunction::kLinear
                                                       : backend::SwitchFunction::kSigmoid;

  try {
    const backend::PoseGraph clean = backend::readG2o(g2o);
    // The outlier-free optimum by plain least squares: the reference without ground truth, and
    // the error every robust run is compared with.
    backend::PoseGraph optimum = clean;
    backend::OptimizerParams plain = params;
    plain.kernel = backend::RobustKernel::kNone;
    const auto optimum_result = backend::PoseGraphOptimizer(plain).optimize(optimum);
    std::vector<ccir_mapping::core::Pose3> reference = optimum.poses;
    if (!gt.empty()) {
      reference = backend::readGroundTruth(gt, clean.dimension);
      if (reference.size() != clean.poses.size()) {
        std::cerr << "pgo_benchmark: " << gt << " has " << reference.size() << " poses, the graph "
                  << clean.poses.size() << '\n';
        return 1;
      }
    }
    const double outlier_free_ate = backend::absoluteTrajectoryError(optimum.poses, reference);
    // MRPT's optimiser on the same outlier-free graph: time, and the cost of its result under
    // this package's cost function (the same edges and conventions).
    std::string mrpt_json = "null";
    if (reference_solver == "mrpt") {
      const MrptReference mrpt = runMrptReference(g2o, clean.dimension, params.max_iterations);
      backend::PoseGraph mrpt_graph = clean;
      if (mrpt.poses.size() == clean.poses.size()) mrpt_graph.poses = mrpt.poses;
      char buffer[256];
      std::snprintf(buffer, sizeof buffer,
                    "{\"solve_s\": %.3f, \"iterations\": %d, \"plain_cost\": %.10g}", mrpt.solve_s,
                    mrpt.iterations, backend::PoseGraphOptimizer::plainCost(mrpt_graph));
      mrpt_json = buffer;
    }

    backend::PoseGraph graph = clean;
    backend::injectOutliers(graph, outliers.count > 0 ? outliers : backend::OutlierParams{0});
    const auto result = backend::PoseGraphOptimizer(params).optimize(graph);
    const double ate = backend::absoluteTrajectoryError(graph.poses, reference);

    std::size_t injected = 0;
    std::size_t rejected = 0;
    std::size_t rejected_outliers = 0;
    std::size_t true_loops = 0;
    std::size_t rejected_true = 0;
    for (std::size_t k = 0; k < graph.edges.size(); ++k) {
      const auto& e = graph.edges[k];
      if (!e.loop) continue;
      injected += e.outlier;
      true_loops += !e.outlier;
      if (!result.inliers[k]) {
        ++rejected;
        rejected_outliers += e.outlier;
        rejected_true += !e.outlier;
      }
    }
    const double precision = rejected ? double(rejected_outliers) / rejected : 1.0;
    const double recall = injected ? double(rejected_outliers) / injected : 1.0;
    std::printf(
        "{\n  \"benchmark\": \"pgo\",\n  \"graph\": %s,\n  \"dimension\": %d,\n  \"poses\": %zu,\n"
        "  \"edges\": %zu,\n  \"true_loops\": %zu,\n  \"outliers\": %zu,\n  \"outlier_mode\": %s,\n"
        "  \"seed\": %d,\n  \"robust\": %s,\n  \"reference\": %s,\n"
        "  \"ate_rmse\": %.6g,\n  \"outlier_free_ate_rmse\": %.6g,\n  \"ate_ratio\": %.4g,\n"
        "  \"initial_cost\": %.10g,\n  \"final_cost\": %.10g,\n  \"plain_cost\": %.10g,\n"
        "  \"iterations\": %d,\n  \"solve_s\": %.3f,\n  \"usable\": %s,\n"
        "  \"outlier_free_solve_s\": %.3f,\n  \"outlier_free_plain_cost\": %.10g,\n"
        "  \"mrpt_reference\": %s,\n"
        "  \"loop_classification\": {\"rejected\": %zu, \"rejected_outliers\": %zu, "
        "\"rejected_true_loops\": %zu, \"precision\": %.4f, \"recall\": %.4f}\n}\n",
        jsonString(g2o).c_str(), clean.dimension, clean.poses.size(), graph.edges.size(),
        true_loops, injected, jsonString(backend::toString(outliers.mode)).c_str(), seed,
        jsonString(backend::toString(params.kernel)).c_str(),
        jsonString(gt.empty() ? "outlier-free optimum" : "ground truth").c_str(), ate,
        outlier_free_ate, outlier_free_ate > 0 ? ate / outlier_free_ate : 0.0, result.initial_cost,
        result.final_cost, backend::PoseGraphOptimizer::plainCost(graph), result.iterations,
        result.solve_s, result.usable ? "true" : "false", optimum_result.solve_s,
        backend::PoseGraphOptimizer::plainCost(optimum), mrpt_json.c_str(), rejected,
        rejected_outliers, rejected_true, precision, recall);
  } catch (const std::exception& e) {
    std::cerr << "pgo_benchmark: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
