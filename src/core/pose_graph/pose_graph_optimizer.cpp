#include "ccir_mapping/core/pose_graph/pose_graph_optimizer.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>
#include <ceres/covariance.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Geometry>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/pose_graph/dcs_loss.h"

namespace ccir_mapping::core::pose_graph {
namespace {

double yawOf(const Pose3& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

Eigen::MatrixXd sqrtInformation(const PoseGraphEdge& edge, int size) {
  if (edge.information.rows() != size || edge.information.cols() != size) {
    throw std::invalid_argument("edge " + std::to_string(edge.from) + " -> " +
                                std::to_string(edge.to) + ": information is not " +
                                std::to_string(size) + " x " + std::to_string(size));
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(edge.information);
  if (llt.info() != Eigen::Success) {
    throw std::invalid_argument("edge " + std::to_string(edge.from) + " -> " +
                                std::to_string(edge.to) + ": information is not positive definite");
  }
  return llt.matrixU();  // U^T U = information
}

Eigen::Vector3d planarOf(const Pose3& pose) {
  return {pose.translation().x(), pose.translation().y(), yawOf(pose)};
}

Edge2D edge2D(const PoseGraphEdge& edge, double scale = 1.0) {
  return {planarOf(edge.measurement), scale * sqrtInformation(edge, 3), edge.hasOffsets(),
          planarOf(edge.from_offset), planarOf(edge.to_offset)};
}

Edge3D edge3D(const PoseGraphEdge& edge, double scale = 1.0) {
  return {edge.measurement.translation(),   Eigen::Quaterniond(edge.measurement.linear()),
          scale * sqrtInformation(edge, 6), edge.hasOffsets(),
          edge.from_offset.translation(),   Eigen::Quaterniond(edge.from_offset.linear()),
          edge.to_offset.translation(),     Eigen::Quaterniond(edge.to_offset.linear())};
}

/// The graph's poses as Ceres parameter blocks: 2D (x y theta); 3D position and quaternion.
struct Parameters {
  std::vector<std::array<double, 3>> planar;
  std::vector<std::array<double, 3>> position;
  std::vector<std::array<double, 4>> rotation;  // x y z w, as Eigen stores it

  explicit Parameters(const PoseGraph& graph) {
    for (const Pose3& pose : graph.poses) {
      if (graph.dimension == 2) {
        planar.push_back({pose.translation().x(), pose.translation().y(), yawOf(pose)});
      } else {
        const Eigen::Quaterniond q(pose.linear());
        position.push_back(
            {pose.translation().x(), pose.translation().y(), pose.translation().z()});
        rotation.push_back({q.x(), q.y(), q.z(), q.w()});
      }
    }
  }

  void writeBack(PoseGraph& graph) const {
    for (std::size_t i = 0; i < graph.poses.size(); ++i) {
      Pose3 pose = Pose3::Identity();
      if (graph.dimension == 2) {
        pose.translation() << planar[i][0], planar[i][1], 0.0;
        pose.linear() =
            Eigen::AngleAxisd(planar[i][2], Eigen::Vector3d::UnitZ()).toRotationMatrix();
      } else {
        pose.translation() << position[i][0], position[i][1], position[i][2];
        pose.linear() =
            Eigen::Quaterniond(rotation[i][3], rotation[i][0], rotation[i][1], rotation[i][2])
                .normalized()
                .toRotationMatrix();
      }
      graph.poses[i] = pose;
    }
  }

  /// Adds the plain (or scaled) residual of `edge`, with `loss` (owned by the problem).
  void addEdge(ceres::Problem& problem, int dimension, const PoseGraphEdge& edge,
               ceres::LossFunction* loss, double scale = 1.0) {
    const auto a = static_cast<std::size_t>(edge.from);
    const auto b = static_cast<std::size_t>(edge.to);
    if (dimension == 2) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Edge2D, 3, 3, 3>(new Edge2D(edge2D(edge, scale))), loss,
          planar[a].data(), planar[b].data());
    } else {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<Edge3D, 6, 3, 4, 3, 4>(new Edge3D(edge3D(edge, scale))),
          loss, position[a].data(), rotation[a].data(), position[b].data(), rotation[b].data());
    }
  }

  /// Quaternion manifolds, and the poses `fixed` says (the first when it says none) constant.
  void finish(ceres::Problem& problem, int dimension, const std::vector<bool>& fixed = {}) {
    if (dimension == 3) {
      for (auto& q : rotation) {
        if (problem.HasParameterBlock(q.data())) {
          problem.SetManifold(q.data(), new ceres::EigenQuaternionManifold);
        }
      }
    }
    const bool any = std::find(fixed.begin(), fixed.end(), true) != fixed.end();
    const std::size_t n = dimension == 2 ? planar.size() : position.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (any ? !fixed[i] : i > 0) continue;
      for (double* block : dimension == 2
                               ? std::vector<double*>{planar[i].data()}
                               : std::vector<double*>{position[i].data(), rotation[i].data()}) {
        if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
      }
    }
  }
};

void checkEdges(const PoseGraph& graph) {
  if (graph.dimension != 2 && graph.dimension != 3) {
    throw std::invalid_argument("pose graph dimension must be 2 or 3");
  }
  const int n = static_cast<int>(graph.poses.size());
  for (const auto& e : graph.edges) {
    if (e.from < 0 || e.to < 0 || e.from >= n || e.to >= n || e.from == e.to) {
      throw std::invalid_argument("edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) +
                                  " refers to a missing pose");
    }
  }
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

namespace {

/// Each pose's odometry edge to the next one (e.from + 1 == e.to, not a loop), or null.
std::vector<const PoseGraphEdge*> odometrySteps(const PoseGraph& graph) {
  std::vector<const PoseGraphEdge*> steps(graph.poses.size(), nullptr);
  for (const auto& e : graph.edges) {
    if (!e.loop && e.to == e.from + 1 && !e.hasOffsets() &&
        !steps[static_cast<std::size_t>(e.from)]) {
      steps[static_cast<std::size_t>(e.from)] = &e;
    }
  }
  return steps;
}

/// The odometry steps from pose `first` to `last` composed, with their covariance in the
/// residual's tangent space (translation in the first pose's frame, rotation a perturbation at
/// the last); nullopt where the chain breaks.
std::optional<std::pair<Pose3, Eigen::MatrixXd>> composeChain(
    const PoseGraph& graph, const std::vector<const PoseGraphEdge*>& steps, int first, int last) {
  const int n = graph.tangentSize();
  Eigen::MatrixXd sigma = Eigen::MatrixXd::Zero(n, n);
  Pose3 composed = Pose3::Identity();
  for (int k = first; k < last; ++k) {
    const PoseGraphEdge* step = steps[static_cast<std::size_t>(k)];
    if (!step) return std::nullopt;
    const Eigen::Matrix3d r = composed.linear();
    const Eigen::Vector3d t = r * step->measurement.translation();
    Eigen::MatrixXd f = Eigen::MatrixXd::Identity(n, n);
    Eigen::MatrixXd g = Eigen::MatrixXd::Identity(n, n);
    if (graph.dimension == 2) {
      f(0, 2) = -t.y();
      f(1, 2) = t.x();
      g.topLeftCorner<2, 2>() = r.topLeftCorner<2, 2>();
    } else {
      f.topRightCorner<3, 3>() = -skew(t);
      g.topLeftCorner<3, 3>() = r;
      g.bottomRightCorner<3, 3>() = r;
    }
    sigma = f * sigma * f.transpose() + g * step->information.inverse() * g.transpose();
    composed = composed * step->measurement;
  }
  if (graph.dimension == 3) {  // the residual's rotation is a perturbation at the last pose
    Eigen::MatrixXd j = Eigen::MatrixXd::Identity(n, n);
    j.bottomRightCorner<3, 3>() = composed.linear().transpose();
    sigma = j * sigma * j.transpose();
  }
  return std::make_pair(composed, sigma);
}

}  // namespace

std::vector<Information> chainInflatedInformation(const PoseGraph& graph) {
  const auto steps = odometrySteps(graph);
  std::vector<Information> result;
  for (const auto& e : graph.edges) {
    result.push_back(e.information);
    if (!e.loop) continue;
    const auto chain = composeChain(graph, steps, std::min(e.from, e.to), std::max(e.from, e.to));
    if (chain) result.back() = (e.information.inverse() + chain->second).inverse();
  }
  return result;
}

PoseGraph thinChains(const PoseGraph& graph, const std::vector<bool>& keep,
                     std::vector<int>* node_of, std::vector<double>* weights) {
  const auto steps = odometrySteps(graph);
  const auto n = graph.poses.size();
  PoseGraph thin;
  thin.dimension = graph.dimension;
  node_of->assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    // A chain's ends stay too: where no step leads in or out.
    const bool end = !steps[i] || i == 0 || !steps[i - 1];
    if (!(end || (i < keep.size() && keep[i]))) continue;
    (*node_of)[i] = static_cast<int>(thin.poses.size());
    thin.poses.push_back(graph.poses[i]);
  }
  // The kept pose nearest each pose along its chain (the ends are kept, so the steps between
  // them are unbroken).
  std::vector<int> nearest(n, -1);
  for (std::size_t i = 0, last = 0; i < n; ++i) {
    if ((*node_of)[i] >= 0) last = i;
    nearest[i] = static_cast<int>(last);
  }
  for (std::size_t i = n, next = n; i-- > 0;) {
    if ((*node_of)[i] >= 0) next = i;
    if (next < n && next - i < i - static_cast<std::size_t>(nearest[i])) {
      nearest[i] = static_cast<int>(next);
    }
  }
  // A loop's end moves to its nearest kept pose: as that pose times the end's offset from it,
  // the chain between them adding its covariance to the loop's (to first order).
  const auto snap = [&](int i, Pose3& offset, Eigen::MatrixXd& covariance) {
    const int at = nearest[static_cast<std::size_t>(i)];
    if (at == i) return (*node_of)[static_cast<std::size_t>(i)];
    // Unbroken: a break's both sides are chain ends, kept, and nearer than `at`.
    const auto chain = composeChain(graph, steps, std::min(at, i), std::max(at, i));
    offset = graph.poses[static_cast<std::size_t>(at)].inverse() *
             graph.poses[static_cast<std::size_t>(i)] * offset;
    covariance += chain->second;
    return (*node_of)[static_cast<std::size_t>(at)];
  };
  std::vector<double> thin_weights;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& e = graph.edges[k];
    const bool step = steps[static_cast<std::size_t>(e.from)] == &e;
    if (step) continue;  // composed below
    PoseGraphEdge mapped = e;
    Eigen::MatrixXd covariance = e.information.inverse();
    mapped.from = snap(e.from, mapped.from_offset, covariance);
    mapped.to = snap(e.to, mapped.to_offset, covariance);
    if (mapped.from == mapped.to) continue;  // both ends moved to one pose: nothing to close
    mapped.information = covariance.inverse();
    thin.edges.push_back(mapped);
    thin_weights.push_back(k < weights->size() ? (*weights)[k] : 1.0);
  }
  int previous = -1;
  for (std::size_t i = 0; i < n; ++i) {
    if ((*node_of)[i] < 0) continue;
    if (previous >= 0 && steps[static_cast<std::size_t>(previous)]) {
      if (const auto chain = composeChain(graph, steps, previous, static_cast<int>(i))) {
        PoseGraphEdge composed;
        composed.from = (*node_of)[static_cast<std::size_t>(previous)];
        composed.to = (*node_of)[i];
        composed.measurement = chain->first;
        composed.information = chain->second.inverse();
        thin.edges.push_back(composed);
        thin_weights.push_back(1.0);
      }
    }
    previous = static_cast<int>(i);
  }
  *weights = std::move(thin_weights);
  return thin;
}

void DcsLoss::Evaluate(double s, double rho[3]) const {
  if (s <= phi_) {
    rho[0] = s;
    rho[1] = 1.0;
    rho[2] = 0.0;
    return;
  }
  const double d = phi_ + s;
  rho[0] = 3.0 * phi_ - 4.0 * phi_ * phi_ / d;
  rho[1] = 4.0 * phi_ * phi_ / (d * d);
  rho[2] = -8.0 * phi_ * phi_ / (d * d * d);
}

double DcsLoss::scale(double phi, double chi2) { return std::min(1.0, 2.0 * phi / (phi + chi2)); }

std::vector<std::string> OptimizerParams::validate() const {
  ParamCheck check;
  check.inRange("switch_prior_sigma", switch_prior_sigma, 0.0, 1000.0);
  check.inRange("dcs_phi", dcs_phi, 0.0, 1e6);
  check.inHalfOpenRange("loss_scale", loss_scale, 0.0, 1e6);
  check.inRange("max_iterations", max_iterations, 1, 100000);
  check.inHalfOpenRange("max_solve_time_s", max_solve_time_s, 0.0, 1e6);
  check.inRange("threads", threads, 1, 256);
  return check.errors();
}

PoseGraphOptimizer::PoseGraphOptimizer(const OptimizerParams& params)
    : params_(validated(params)) {}

OptimizationResult PoseGraphOptimizer::optimize(PoseGraph& graph, std::optional<double> max_time_s,
                                                const SolveStart& start) const {
  const double budget_s = max_time_s.value_or(params_.max_solve_time_s);
  checkEdges(graph);
  if (!start.fixed.empty() && start.fixed.size() != graph.poses.size()) {
    throw std::invalid_argument("SolveStart: fixed needs one entry per pose");
  }
  if (!start.switches.empty() && start.switches.size() != graph.edges.size()) {
    throw std::invalid_argument("SolveStart: switches needs one entry per edge");
  }
  const std::vector<bool>& fixed = start.fixed;
  OptimizationResult result;
  result.weights.assign(graph.edges.size(), 1.0);
  result.inliers.assign(graph.edges.size(), true);
  const std::vector<double> initial_switches(graph.edges.size(), initialSwitch());
  std::vector<double> switches = start.switches.empty() ? initial_switches : start.switches;
  result.switches = switches;
  if (graph.poses.size() < 2 || graph.edges.empty()) {
    result.usable = true;
    return result;
  }
  const PoseGraph initial = graph;
  // max_solve_time_s bounds the whole optimisation: each solve gets what the ones before left,
  // and the optional ones (retry, refinement) are skipped when nothing is left.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(budget_s);
  const auto remaining = [&] {
    return std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
  };
  solve(graph, fixed, switches, result, budget_s);
  classify(graph, switches, result);

  // Most loops off can mean false loops, or true ones seen after drift larger than their
  // covariance: try again from a first solve with chain-inflated loops and keep the solution
  // with the lower cost (the same robust objective).
  std::size_t loops = 0;
  std::size_t rejected = 0;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    loops += graph.edges[k].loop;
    rejected += graph.edges[k].loop && !result.inliers[k];
  }
  if (params_.uncertainty_aware_start && params_.kernel != RobustKernel::kNone &&
      2 * rejected > loops && remaining() > 0.0) {
    PoseGraph inflated = initial;
    const std::vector<Information> information = chainInflatedInformation(initial);
    for (std::size_t k = 0; k < inflated.edges.size(); ++k) {
      inflated.edges[k].information = information[k];
    }
    std::vector<double> retry_switches = initial_switches;
    OptimizationResult first;
    solve(inflated, fixed, retry_switches, first, remaining());
    PoseGraph retry = initial;
    retry.poses = inflated.poses;
    OptimizationResult second;
    second.weights = result.weights;
    second.inliers = result.inliers;
    solve(retry, fixed, retry_switches, second, std::max(remaining(), 1e-3));
    second.iterations += first.iterations + result.iterations;
    second.solve_s += first.solve_s + result.solve_s;
    if (second.usable && second.final_cost < result.final_cost) {
      second.initial_cost = result.initial_cost;
      graph.poses = retry.poses;
      switches = retry_switches;
      result = second;
      classify(graph, switches, result);
    } else {
      result.iterations = second.iterations;
      result.solve_s = second.solve_s;
    }
  }
  if (params_.refine_inliers && params_.kernel != RobustKernel::kNone && remaining() > 0.0) {
    // Loops kept only partly on still pull a little: finish with the kept loops at full weight
    // and the rejected ones out.
    PoseGraph kept = graph;
    kept.edges.clear();
    for (std::size_t k = 0; k < graph.edges.size(); ++k) {
      if (result.inliers[k]) {
        kept.edges.push_back(graph.edges[k]);
        kept.edges.back().loop = false;  // plain
      }
    }
    std::vector<double> unused(kept.edges.size(), 1.0);
    OptimizationResult refined;
    solve(kept, fixed, unused, refined, remaining());
    if (refined.usable) {
      graph.poses = kept.poses;
      result.iterations += refined.iterations;
      result.solve_s += refined.solve_s;
    }
  }
  result.switches = switches;
  return result;
}

void PoseGraphOptimizer::classify(const PoseGraph& graph, const std::vector<double>& switches,
                                  OptimizationResult& result) const {
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& edge = graph.edges[k];
    if (!edge.loop) continue;
    switch (params_.kernel) {
      case RobustKernel::kSwitchable:
        result.weights[k] = switchValue(switches[k], params_.switch_function);
        result.inliers[k] = result.weights[k] >= 0.5;
        break;
      case RobustKernel::kDcs:
        result.weights[k] = DcsLoss::scale(dcsPhi(graph.dimension), chi2(graph, edge));
        result.inliers[k] = result.weights[k] >= 0.5;
        break;
      default:
        result.inliers[k] = chi2(graph, edge) <= outlierChi2(graph.dimension);
    }
  }
}

double PoseGraphOptimizer::switchPriorSigma(int dimension) const {
  return params_.switch_prior_sigma > 0.0 ? params_.switch_prior_sigma
                                          : 1.0 / std::sqrt(outlierChi2(dimension));
}

double PoseGraphOptimizer::dcsPhi(int dimension) const {
  return params_.dcs_phi > 0.0 ? params_.dcs_phi : outlierChi2(dimension) / 3.0;
}

void PoseGraphOptimizer::solve(PoseGraph& graph, const std::vector<bool>& fixed,
                               std::vector<double>& switches, OptimizationResult& result,
                               double time_limit_s) const {
  const bool linear = params_.switch_function == SwitchFunction::kLinear;
  const double switch_start = initialSwitch();

  Parameters parameters(graph);
  ceres::Problem problem;
  const int dim = graph.dimension;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& edge = graph.edges[k];
    if (!edge.loop || params_.kernel == RobustKernel::kNone) {
      parameters.addEdge(problem, dim, edge, nullptr);
      continue;
    }
    switch (params_.kernel) {
      case RobustKernel::kCauchy:
        parameters.addEdge(problem, dim, edge, new ceres::CauchyLoss(params_.loss_scale));
        break;
      case RobustKernel::kHuber:
        parameters.addEdge(problem, dim, edge, new ceres::HuberLoss(params_.loss_scale));
        break;
      case RobustKernel::kDcs:
        parameters.addEdge(problem, dim, edge, new DcsLoss(dcsPhi(dim)));
        break;
      default: {
        const auto a = static_cast<std::size_t>(edge.from);
        const auto b = static_cast<std::size_t>(edge.to);
        double* s = &switches[k];
        if (dim == 2) {
          problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Switchable2D, 3, 3, 3, 1>(
                                       new Switchable2D{edge2D(edge), params_.switch_function}),
                                   nullptr, parameters.planar[a].data(),
                                   parameters.planar[b].data(), s);
        } else {
          problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Switchable3D, 6, 3, 4, 3, 4, 1>(
                                       new Switchable3D{edge3D(edge), params_.switch_function}),
                                   nullptr, parameters.position[a].data(),
                                   parameters.rotation[a].data(), parameters.position[b].data(),
                                   parameters.rotation[b].data(), s);
        }
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SwitchPrior, 1, 1>(
                                     new SwitchPrior{switch_start, 1.0 / switchPriorSigma(dim)}),
                                 nullptr, s);
        // Bounds need the trust-region minimiser (the default).
        problem.SetParameterLowerBound(s, 0, linear ? 0.0 : -10.0);
        problem.SetParameterUpperBound(s, 0, linear ? 1.0 : 10.0);
      }
    }
  }
  parameters.finish(problem, dim, fixed);

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = params_.max_iterations;
  options.max_solver_time_in_seconds = std::max(time_limit_s, 1e-3);
  options.num_threads = params_.threads;
  options.function_tolerance = 1e-7;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(options, &problem, &summary);
  result.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.usable = summary.IsSolutionUsable();
  result.summary = summary.BriefReport();
  parameters.writeBack(graph);
}

double PoseGraphOptimizer::chi2(const PoseGraph& graph, const PoseGraphEdge& edge) {
  const Pose3& a = graph.poses.at(static_cast<std::size_t>(edge.from));
  const Pose3& b = graph.poses.at(static_cast<std::size_t>(edge.to));
  if (graph.dimension == 2) {
    const double pa[3] = {a.translation().x(), a.translation().y(), yawOf(a)};
    const double pb[3] = {b.translation().x(), b.translation().y(), yawOf(b)};
    Eigen::Vector3d r;
    edge2D(edge)(pa, pb, r.data());
    return r.squaredNorm();
  }
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  Eigen::Matrix<double, 6, 1> r;
  edge3D(edge)(a.translation().data(), qa.coeffs().data(), b.translation().data(),
               qb.coeffs().data(), r.data());
  return r.squaredNorm();
}

double PoseGraphOptimizer::plainCost(const PoseGraph& graph) {
  double cost = 0.0;
  for (const auto& edge : graph.edges) cost += chi2(graph, edge);
  return cost;
}

std::optional<std::vector<Eigen::MatrixXd>> PoseGraphOptimizer::marginalCovariances(
    const PoseGraph& graph, const std::vector<int>& ids, const std::vector<double>& weights) const {
  checkEdges(graph);
  Parameters parameters(graph);
  ceres::Problem problem;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const double weight = k < weights.size() ? weights[k] : 1.0;
    if (weight <= 0.0) continue;
    parameters.addEdge(problem, graph.dimension, graph.edges[k], nullptr, weight);
  }
  parameters.finish(problem, graph.dimension);

  ceres::Covariance::Options options;
  options.num_threads = params_.threads;
  ceres::Covariance covariance(options);
  std::vector<std::pair<const double*, const double*>> pairs;
  auto blocks = [&](int id) -> std::vector<const double*> {
    const auto i = static_cast<std::size_t>(id);
    if (graph.dimension == 2) return {parameters.planar[i].data()};
    return {parameters.position[i].data(), parameters.rotation[i].data()};
  };
  for (const int id : ids) {
    if (id < 0 || id >= static_cast<int>(graph.poses.size())) return std::nullopt;
    const auto b = blocks(id);
    for (const double* x : b) {
      if (!problem.HasParameterBlock(x)) return std::nullopt;
      for (const double* y : b) pairs.emplace_back(x, y);
    }
  }
  if (!covariance.Compute(pairs, &problem)) return std::nullopt;

  std::vector<Eigen::MatrixXd> result;
  for (const int id : ids) {
    const int n = graph.tangentSize();
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(n, n);
    if (!covariance.GetCovarianceMatrixInTangentSpace(blocks(id), c.data())) return std::nullopt;
    // From Ceres' tangent spaces (world-frame position; 2D angle, or the quaternion manifold's
    // left-multiplied half-angle vector) to the pose frame and a rotation vector.
    const Eigen::Matrix3d rt = graph.poses[static_cast<std::size_t>(id)].linear().transpose();
    Eigen::MatrixXd j = Eigen::MatrixXd::Identity(n, n);
    if (graph.dimension == 2) {
      j.topLeftCorner<2, 2>() = rt.topLeftCorner<2, 2>();
    } else {
      j.topLeftCorner<3, 3>() = rt;
      j.bottomRightCorner<3, 3>() = 2.0 * rt;
    }
    result.push_back(j * c * j.transpose());
  }
  return result;
}

}  // namespace ccir_mapping::core::pose_graph
