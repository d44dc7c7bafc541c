// pgo_benchmark: a g2o pose graph, optionally with injected false loop closures, optimised with
// a chosen robust treatment; prints JSON with the trajectory error (against ground truth, or
// against the outlier-free optimum), cost, iterations, time and loop classification.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/pose_graph/g2o_io.h"
#include "ccir_mapping/core/pose_graph/pose_graph_optimizer.h"
#include "ccir_mapping/core/testing/outlier_injector.h"
#include "ccir_mapping/core/testing/trajectory_error.h"
#include "command_line.h"
#include "mrpt_reference.h"

namespace po = boost::program_options;
namespace pose_graph = ccir_mapping::core::pose_graph;
namespace testing = ccir_mapping::core::testing;
namespace tools = ccir_mapping::tools;

namespace {

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

struct Options {
  std::string g2o;
  std::string gt;
  /// "mrpt" to compare with MRPT's optimiser, or "".
  std::string reference_solver;
  testing::OutlierParams outliers;
  int seed = 1;
  pose_graph::OptimizerParams params;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  std::string robust = "switchable";
  std::string switch_function = "linear";
  std::string outlier_mode = "random";
  o->outliers.count = 0;
  po::options_description options(
      "Usage: pgo_benchmark --g2o FILE [--gt FILE] [--outliers N] [--outlier-mode random|local|"
      "grouped]\n                     [--inter-robot] [--seed S] [--robust "
      "none|cauchy|huber|dcs|switchable] "
      "[--json]\nPrints JSON.\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "g2o", po::value<std::string>(&o->g2o), "pose graph (VERTEX/EDGE_SE2 or _SE3:QUAT)")(
      "gt", po::value<std::string>(&o->gt),
      "ground-truth poses ([id] x y theta | [id] x y z qx qy qz qw); without it the error is "
      "against the outlier-free least-squares optimum")(
      "outliers", po::value<int>(&o->outliers.count)->default_value(0),
      "false loop closures to add")(
      "outlier-mode", po::value<std::string>(&outlier_mode)->default_value(outlier_mode),
      "random | local | grouped")(
      "group-size", po::value<int>(&o->outliers.group_size)->default_value(o->outliers.group_size),
      "edges per group (grouped)")(
      "inter-robot", "false closures only between robots (a multi-robot graph: robot-keyed ids)")(
      "seed", po::value<int>(&o->seed)->default_value(o->seed), "outlier seed")(
      "robust", po::value<std::string>(&robust)->default_value(robust),
      "none | cauchy | huber | dcs | switchable")(
      "switch", po::value<std::string>(&switch_function)->default_value(switch_function),
      "switch function: linear | sigmoid")(
      "dcs-phi", po::value<double>(&o->params.dcs_phi)->default_value(o->params.dcs_phi),
      "DCS phi in chi^2 units; 0: auto (99 % quantile / 3)")(
      "switch-prior-sigma",
      po::value<double>(&o->params.switch_prior_sigma)->default_value(o->params.switch_prior_sigma),
      "switch prior sigma; 0: auto (1 / sqrt of the 99 % chi^2 quantile)")(
      "no-chain-start", "skip the first solve with chain-inflated loop covariances")(
      "max-iterations",
      po::value<int>(&o->params.max_iterations)->default_value(o->params.max_iterations),
      "solver iterations")("threads",
                           po::value<int>(&o->params.threads)->default_value(o->params.threads),
                           "solver threads")(
      "reference", po::value<std::string>(&o->reference_solver),
      "mrpt: also run MRPT's optimiser on the outlier-free graph and compare "
      "time and cost")("json", "print JSON (the only output format; accepted for scripts)");
  po::variables_map arguments;
  if (const auto exit_code =
          tools::parseCommandLine("pgo_benchmark", options, argc, argv, &arguments)) {
    return exit_code;
  }
  const auto kernel = pose_graph::parseRobustKernel(robust);
  const auto mode = testing::parseOutlierMode(outlier_mode);
  if (!o->reference_solver.empty() && o->reference_solver != "mrpt") {
    return tools::usageError("pgo_benchmark", "--reference allows only mrpt");
  }
  if (o->g2o.empty() || !kernel || !mode || o->outliers.count < 0 ||
      (switch_function != "linear" && switch_function != "sigmoid")) {
    return tools::usageError(
        "pgo_benchmark", "need --g2o FILE, --robust " +
                             std::string(pose_graph::kRobustKernelChoices) + ", --outlier-mode " +
                             std::string(testing::kOutlierModeChoices) +
                             ", --switch linear | sigmoid, --outliers >= 0 (see --help)");
  }
  o->outliers.mode = *mode;
  o->outliers.inter_robot = arguments.count("inter-robot") > 0;
  o->outliers.seed = static_cast<std::uint64_t>(o->seed);
  o->params.kernel = *kernel;
  o->params.uncertainty_aware_start = arguments.count("no-chain-start") == 0;
  o->params.switch_function = switch_function == "linear" ? pose_graph::SwitchFunction::kLinear
                                                          : pose_graph::SwitchFunction::kSigmoid;
  return std::nullopt;
}

struct Results {
  pose_graph::PoseGraph clean;  // as read
  pose_graph::PoseGraph graph;  // with the outliers, optimised
  pose_graph::OptimizationResult result;
  pose_graph::PoseGraph optimum;  // outlier-free, by plain least squares
  pose_graph::OptimizationResult optimum_result;
  double ate = 0, outlier_free_ate = 0;
  /// MRPT's time, iterations and the cost of its result under this package's cost function,
  /// as JSON ("null" without --reference).
  std::string mrpt_json = "null";
  std::size_t injected = 0, rejected = 0, rejected_outliers = 0, true_loops = 0, rejected_true = 0;
  std::size_t robots = 1, inter_robot_true_loops = 0, inter_robot_rejected_true = 0;
};

/// Throws std::runtime_error (a file that cannot be read, ground truth of another size).
Results run(const Options& o) {
  Results r;
  r.clean = pose_graph::readG2o(o.g2o);
  // The outlier-free optimum by plain least squares: the reference without ground truth, and
  // the error every robust run is compared with.
  r.optimum = r.clean;
  pose_graph::OptimizerParams plain = o.params;
  plain.kernel = pose_graph::RobustKernel::kNone;
  r.optimum_result = pose_graph::PoseGraphOptimizer(plain).optimize(r.optimum);
  std::vector<ccir_mapping::core::Pose3> reference = r.optimum.poses;
  if (!o.gt.empty()) {
    reference = pose_graph::readGroundTruth(o.gt, r.clean.dimension);
    if (reference.size() != r.clean.poses.size()) {
      throw std::runtime_error(o.gt + " has " + std::to_string(reference.size()) +
                               " poses, the graph " + std::to_string(r.clean.poses.size()));
    }
  }
  r.outlier_free_ate = testing::absoluteTrajectoryError(r.optimum.poses, reference);
  if (o.reference_solver == "mrpt") {
    const MrptReference mrpt = runMrptReference(o.g2o, r.clean.dimension, o.params.max_iterations);
    pose_graph::PoseGraph mrpt_graph = r.clean;
    if (mrpt.poses.size() == r.clean.poses.size()) mrpt_graph.poses = mrpt.poses;
    char buffer[256];
    std::snprintf(buffer, sizeof buffer,
                  "{\"solve_s\": %.3f, \"iterations\": %d, \"plain_cost\": %.10g}", mrpt.solve_s,
                  mrpt.iterations, pose_graph::PoseGraphOptimizer::plainCost(mrpt_graph));
    r.mrpt_json = buffer;
  }

  r.graph = r.clean;
  testing::injectOutliers(r.graph, o.outliers.count > 0 ? o.outliers : testing::OutlierParams{0});
  r.result = pose_graph::PoseGraphOptimizer(o.params).optimize(r.graph);
  r.ate = testing::absoluteTrajectoryError(r.graph.poses, reference);
  for (std::size_t k = 0; k < r.graph.edges.size(); ++k) {
    const auto& e = r.graph.edges[k];
    if (!e.loop) continue;
    const bool inter_robot =
        !r.graph.keys.empty() && r.graph.keys[e.from].robot != r.graph.keys[e.to].robot;
    r.injected += e.outlier;
    r.true_loops += !e.outlier;
    r.inter_robot_true_loops += !e.outlier && inter_robot;
    if (!r.result.inliers[k]) {
      ++r.rejected;
      r.rejected_outliers += e.outlier;
      r.rejected_true += !e.outlier;
      r.inter_robot_rejected_true += !e.outlier && inter_robot;
    }
  }
  for (std::size_t i = 1; i < r.graph.keys.size(); ++i) {
    r.robots += r.graph.keys[i].robot != r.graph.keys[i - 1].robot;
  }
  return r;
}

void report(const Options& o, const Results& r) {
  const double precision = r.rejected ? double(r.rejected_outliers) / r.rejected : 1.0;
  const double recall = r.injected ? double(r.rejected_outliers) / r.injected : 1.0;
  std::printf(
      "{\n  \"benchmark\": \"pgo\",\n  \"graph\": %s,\n  \"dimension\": %d,\n  \"poses\": %zu,\n"
      "  \"edges\": %zu,\n  \"true_loops\": %zu,\n  \"outliers\": %zu,\n  \"outlier_mode\": %s,\n"
      "  \"robots\": %zu,\n  \"inter_robot_true_loops\": %zu,\n  \"inter_robot_outliers\": %s,\n"
      "  \"seed\": %d,\n  \"robust\": %s,\n  \"reference\": %s,\n"
      "  \"ate_rmse\": %.6g,\n  \"outlier_free_ate_rmse\": %.6g,\n  \"ate_ratio\": %.4g,\n"
      "  \"initial_cost\": %.10g,\n  \"final_cost\": %.10g,\n  \"plain_cost\": %.10g,\n"
      "  \"iterations\": %d,\n  \"solve_s\": %.3f,\n  \"usable\": %s,\n"
      "  \"outlier_free_solve_s\": %.3f,\n  \"outlier_free_plain_cost\": %.10g,\n"
      "  \"mrpt_reference\": %s,\n"
      "  \"loop_classification\": {\"rejected\": %zu, \"rejected_outliers\": %zu, "
      "\"rejected_true_loops\": %zu, \"rejected_inter_robot_true_loops\": %zu, \"precision\": "
      "%.4f, "
      "\"recall\": %.4f}\n}\n",
      jsonString(o.g2o).c_str(), r.clean.dimension, r.clean.poses.size(), r.graph.edges.size(),
      r.true_loops, r.injected, jsonString(testing::toString(o.outliers.mode)).c_str(), r.robots,
      r.inter_robot_true_loops, o.outliers.inter_robot ? "true" : "false", o.seed,
      jsonString(pose_graph::toString(o.params.kernel)).c_str(),
      jsonString(o.gt.empty() ? "outlier-free optimum" : "ground truth").c_str(), r.ate,
      r.outlier_free_ate, r.outlier_free_ate > 0 ? r.ate / r.outlier_free_ate : 0.0,
      r.result.initial_cost, r.result.final_cost,
      pose_graph::PoseGraphOptimizer::plainCost(r.graph), r.result.iterations, r.result.solve_s,
      r.result.usable ? "true" : "false", r.optimum_result.solve_s,
      pose_graph::PoseGraphOptimizer::plainCost(r.optimum), r.mrpt_json.c_str(), r.rejected,
      r.rejected_outliers, r.rejected_true, r.inter_robot_rejected_true, precision, recall);
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("pgo_benchmark", argc, argv, parse, run, report);
}
