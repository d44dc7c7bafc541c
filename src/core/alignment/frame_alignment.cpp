#include "ccir_mapping/core/alignment/frame_alignment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <ceres/autodiff_cost_function.h>
#include <ceres/covariance.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/pose_graph/pose_graph_residuals.h"

namespace ccir_mapping::core::alignment {
namespace {

using pose_graph::Edge3D;

/// Candidate k's error for a transform T (given as translation t and rotation q), weighted by
/// `edge.sqrt_information`: the pose-graph residual between x^a_i and T x^b_j.
struct AlignmentResidual {
  Edge3D edge;
  Eigen::Vector3d pa;
  Eigen::Quaterniond qa;
  Eigen::Vector3d pb;
  Eigen::Quaterniond qb;

  template <class T>
  bool evaluate(const Eigen::Matrix<T, 3, 1>& t, const Eigen::Quaternion<T>& q, T* residual) const {
    const Eigen::Matrix<T, 3, 1> p_b = q * pb.cast<T>() + t;
    const Eigen::Quaternion<T> q_b = q * qb.cast<T>();
    const Eigen::Matrix<T, 3, 1> p_a = pa.cast<T>();
    const Eigen::Quaternion<T> q_a = qa.cast<T>();
    return edge(p_a.data(), q_a.coeffs().data(), p_b.data(), q_b.coeffs().data(), residual);
  }
};

/// x y z yaw.
struct Residual4Dof {
  AlignmentResidual r;
  template <class T>
  bool operator()(const T* x, T* residual) const {
    const Eigen::Quaternion<T> q(Eigen::AngleAxis<T>(x[3], Eigen::Matrix<T, 3, 1>::UnitZ()));
    return r.evaluate(Eigen::Matrix<T, 3, 1>(x[0], x[1], x[2]), q, residual);
  }
};

struct Residual6Dof {
  AlignmentResidual r;
  template <class T>
  bool operator()(const T* t, const T* q, T* residual) const {
    return r.evaluate(Eigen::Matrix<T, 3, 1>(t[0], t[1], t[2]),
                      Eigen::Quaternion<T>(q[3], q[0], q[1], q[2]), residual);
  }
};

double yawOf(const Eigen::Matrix3d& r) { return std::atan2(r(1, 0), r(0, 0)); }

Pose3 make4Dof(const Eigen::Vector3d& t, double yaw) {
  Pose3 pose = Pose3::Identity();
  pose.translation() = t;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

struct Prepared {
  std::vector<Pose3> implied;        // T_k = x^a_i z (x^b_j)^-1
  std::vector<Matrix6> information;  // effective covariance, inverted
  std::vector<Matrix6> sqrt_information;
  std::vector<double> log_normaliser;  // -0.5 log((2 pi)^6 det)
};

/// One EM run from `start`. Returns the final transform, weights and log-likelihood trace.
struct Hypothesis {
  Pose3 transform;
  std::vector<double> weights;
  std::vector<double> trace;
  int inliers = 0;
  Matrix6 covariance = Matrix6::Zero();
};

class Em {
 public:
  Em(const std::vector<AlignmentCandidate>& candidates, const AlignmentParams& params,
     const Prepared& prepared)
      : candidates_(candidates), params_(params), prepared_(prepared) {
    log_outlier_ = -std::log(std::pow(params.outlier_extent_m, 3) * 8.0 * M_PI * M_PI * M_PI);
  }

  Hypothesis run(Pose3 transform) const {
    Hypothesis h;
    if (params_.four_dof) transform = make4Dof(transform.translation(), yawOf(transform.linear()));
    double previous = -std::numeric_limits<double>::infinity();
    for (int iteration = 0; iteration < params_.max_iterations; ++iteration) {
      const double log_likelihood = expectation(transform, &h.weights);
      h.trace.push_back(log_likelihood);
      if (std::abs(log_likelihood - previous) < 1e-6 * std::max(1.0, std::abs(log_likelihood))) {
        break;
      }
      previous = log_likelihood;
      transform = maximisation(transform, h.weights, nullptr);
    }
    h.transform = transform;
    h.trace.push_back(expectation(transform, &h.weights));
    h.inliers = static_cast<int>(
        std::count_if(h.weights.begin(), h.weights.end(), [](double w) { return w > 0.5; }));
    maximisation(transform, h.weights, &h.covariance);
    return h;
  }

  /// E-step: inlier probabilities; returns the log-likelihood.
  double expectation(const Pose3& transform, std::vector<double>* weights) const {
    weights->assign(candidates_.size(), 0.0);
    double log_likelihood = 0.0;
    const double log_prior_in = std::log(params_.inlier_prior);
    const double log_prior_out = std::log(1.0 - params_.inlier_prior) + log_outlier_;
    for (std::size_t k = 0; k < candidates_.size(); ++k) {
      const Eigen::Matrix<double, 6, 1> e = error(k, transform);
      const double log_in =
          log_prior_in + prepared_.log_normaliser[k] - 0.5 * e.dot(prepared_.information[k] * e);
      const double top = std::max(log_in, log_prior_out);
      const double total = top + std::log(std::exp(log_in - top) + std::exp(log_prior_out - top));
      (*weights)[k] = std::exp(log_in - total);
      log_likelihood += total;
    }
    return log_likelihood;
  }

  int inliersOf(const Pose3& transform) const {
    std::vector<double> weights;
    expectation(transform, &weights);
    return static_cast<int>(
        std::count_if(weights.begin(), weights.end(), [](double w) { return w > 0.5; }));
  }

 private:
  Eigen::Matrix<double, 6, 1> error(std::size_t k, const Pose3& transform) const {
    const AlignmentCandidate& c = candidates_[k];
    const AlignmentResidual r{
        Edge3D{c.measurement.translation(), Eigen::Quaterniond(c.measurement.linear()),
               Matrix6::Identity()},
        c.pose_a.translation(), Eigen::Quaterniond(c.pose_a.linear()), c.pose_b.translation(),
        Eigen::Quaterniond(c.pose_b.linear())};
    Eigen::Matrix<double, 6, 1> e;
    r.evaluate<double>(transform.translation(), Eigen::Quaterniond(transform.linear()), e.data());
    return e;
  }

  /// M-step: weighted least squares over the transform (Ceres); optionally its covariance.
  Pose3 maximisation(const Pose3& start, const std::vector<double>& weights,
                     Matrix6* covariance) const {
    ceres::Problem problem;
    double x[4] = {start.translation().x(), start.translation().y(), start.translation().z(),
                   yawOf(start.linear())};
    double t[3] = {start.translation().x(), start.translation().y(), start.translation().z()};
    Eigen::Quaterniond q0(start.linear());
    double q[4] = {q0.x(), q0.y(), q0.z(), q0.w()};
    int residuals = 0;
    for (std::size_t k = 0; k < candidates_.size(); ++k) {
      if (weights[k] < 1e-6) continue;
      const AlignmentCandidate& c = candidates_[k];
      const AlignmentResidual r{
          Edge3D{c.measurement.translation(), Eigen::Quaterniond(c.measurement.linear()),
                 std::sqrt(weights[k]) * prepared_.sqrt_information[k]},
          c.pose_a.translation(), Eigen::Quaterniond(c.pose_a.linear()), c.pose_b.translation(),
          Eigen::Quaterniond(c.pose_b.linear())};
      if (params_.four_dof) {
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<Residual4Dof, 6, 4>(new Residual4Dof{r}), nullptr, x);
      } else {
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<Residual6Dof, 6, 3, 4>(new Residual6Dof{r}), nullptr, t,
            q);
      }
      ++residuals;
    }
    if (residuals == 0) return start;
    if (!params_.four_dof) problem.SetManifold(q, new ceres::EigenQuaternionManifold);
    ceres::Solver::Options options;
    options.max_num_iterations = 20;
    options.linear_solver_type = ceres::DENSE_QR;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);

    if (covariance) {
      covariance->setZero();
      ceres::Covariance::Options covariance_options;
      covariance_options.algorithm_type = ceres::DENSE_SVD;
      covariance_options.null_space_rank = -1;
      ceres::Covariance estimator(covariance_options);
      if (params_.four_dof) {
        using Pairs = std::vector<std::pair<const double*, const double*>>;
        if (estimator.Compute(Pairs{{x, x}}, &problem)) {
          Eigen::Matrix<double, 4, 4, Eigen::RowMajor> c4;
          estimator.GetCovarianceBlock(x, x, c4.data());
          const int map[4] = {0, 1, 2, 5};  // x y z yaw
          for (int r = 0; r < 4; ++r) {
            for (int c = 0; c < 4; ++c) (*covariance)(map[r], map[c]) = c4(r, c);
          }
        }
      } else if (estimator.Compute(
                     std::vector<std::pair<const double*, const double*>>{{t, t}, {t, q}, {q, q}},
                     &problem)) {
        Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c6;
        estimator.GetCovarianceMatrixInTangentSpace({t, q}, c6.data());
        *covariance = c6;
        covariance->bottomRightCorner<3, 3>() *= 4.0;  // half-angle tangent to rotation vector
        covariance->topRightCorner<3, 3>() *= 2.0;
        covariance->bottomLeftCorner<3, 3>() *= 2.0;
      }
    }
    if (params_.four_dof) return make4Dof(Eigen::Vector3d(x[0], x[1], x[2]), x[3]);
    Pose3 result = Pose3::Identity();
    result.translation() << t[0], t[1], t[2];
    result.linear() = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
    return result;
  }

  const std::vector<AlignmentCandidate>& candidates_;
  const AlignmentParams& params_;
  const Prepared& prepared_;
  double log_outlier_;
};

/// Throws std::invalid_argument for a covariance that is not positive definite.
Prepared prepare(const std::vector<AlignmentCandidate>& candidates, const AlignmentParams& params) {
  Prepared prepared;
  for (const auto& c : candidates) {
    prepared.implied.push_back(c.pose_a * c.measurement * c.pose_b.inverse());
    Matrix6 sigma = c.covariance;
    if (params.use_pose_uncertainty) sigma += c.covariance_a + c.covariance_b;
    const Eigen::LLT<Matrix6> llt(sigma);
    if (llt.info() != Eigen::Success || !sigma.allFinite()) {
      throw std::invalid_argument("a candidate's covariance is not positive definite");
    }
    prepared.information.push_back(sigma.inverse());
    prepared.sqrt_information.push_back(Eigen::LLT<Matrix6>(sigma.inverse()).matrixU());
    prepared.log_normaliser.push_back(-0.5 *
                                      (6.0 * std::log(2.0 * M_PI) + std::log(sigma.determinant())));
  }
  return prepared;
}

bool distinct(const Pose3& a, const Pose3& b) {
  const Pose3 d = a.inverse() * b;
  return d.translation().norm() > 1.0 || Eigen::AngleAxisd(d.linear()).angle() > 5.0 * M_PI / 180;
}

}  // namespace

std::vector<std::string> AlignmentParams::validate() const {
  ParamCheck check;
  check.inRange("min_inliers", min_inliers, 1, 100000);
  check.inRange("min_inlier_margin", min_inlier_margin, 0, 100000);
  check.inRange("inlier_prior", inlier_prior, 0.01, 0.99);
  check.inHalfOpenRange("outlier_extent_m", outlier_extent_m, 0.0, 1e6);
  check.inRange("max_iterations", max_iterations, 1, 10000);
  check.inHalfOpenRange("cluster_yaw_scale_m", cluster_yaw_scale_m, 0.0, 1e6);
  check.inRange("max_support_starts", max_support_starts, 1, 1000000);
  check.inRange("max_time_s", max_time_s, 0.0, 1e6);
  return check.errors();
}

AlignmentResult estimateFrameTransform(const std::vector<AlignmentCandidate>& candidates,
                                       const AlignmentParams& params) {
  validated(params);
  const auto begin = std::chrono::steady_clock::now();
  AlignmentResult result;
  const int n = static_cast<int>(candidates.size());
  result.weights.assign(candidates.size(), 0.0);
  result.inliers.assign(candidates.size(), false);
  if (n < params.min_inliers) {
    result.reason = "only " + std::to_string(n) + " candidates: need " +
                    std::to_string(params.min_inliers) + " inliers";
    return result;
  }

  const Prepared prepared = prepare(candidates, params);
  const Em em(candidates, params, prepared);

  // Starts: the candidate nearest each k-means centre of the implied transforms, and the
  // implied transforms most others agree with.
  std::vector<Pose3> starts;
  cv::Mat features(n, 5, CV_32F);
  for (int k = 0; k < n; ++k) {
    const Pose3& t = prepared.implied[static_cast<std::size_t>(k)];
    const double yaw = yawOf(t.linear());
    const float row[5] = {static_cast<float>(t.translation().x()),
                          static_cast<float>(t.translation().y()),
                          static_cast<float>(t.translation().z()),
                          static_cast<float>(params.cluster_yaw_scale_m * std::cos(yaw)),
                          static_cast<float>(params.cluster_yaw_scale_m * std::sin(yaw))};
    std::copy(row, row + 5, features.ptr<float>(k));
  }
  const int clusters = std::clamp(n / 5, 2, 12);
  cv::Mat labels;
  cv::Mat centers;
  cv::theRNG().state = static_cast<std::uint64_t>(params.seed) + 1;
  cv::kmeans(features, clusters, labels,
             cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-3), 3,
             cv::KMEANS_PP_CENTERS, centers);
  for (int c = 0; c < clusters; ++c) {
    int nearest = -1;
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < n; ++k) {
      const double d = cv::norm(features.row(k) - centers.row(c));
      if (d < best) {
        best = d;
        nearest = k;
      }
    }
    if (nearest >= 0) starts.push_back(prepared.implied[static_cast<std::size_t>(nearest)]);
  }
  // Support is counted over all candidates for at most max_support_starts of them (evenly
  // spread): counting it for each of n is O(n^2), seconds once a long mission has thousands.
  std::vector<std::pair<int, int>> support;  // (agreeing candidates, k)
  const int sampled = std::min(n, params.max_support_starts);
  for (int i = 0; i < sampled; ++i) {
    const int k = static_cast<int>(static_cast<long>(i) * n / sampled);
    support.emplace_back(em.inliersOf(prepared.implied[static_cast<std::size_t>(k)]), k);
  }
  std::sort(support.rbegin(), support.rend());
  // The best supported starts run first: when time runs out, the rest are skipped.
  std::vector<Pose3> supported;
  for (std::size_t i = 0; i < support.size() && supported.size() < 5; ++i) {
    const Pose3& t = prepared.implied[static_cast<std::size_t>(support[i].second)];
    if (std::all_of(supported.begin(), supported.end(),
                    [&](const Pose3& s) { return distinct(s, t); })) {
      supported.push_back(t);
    }
  }
  starts.insert(starts.begin(), supported.begin(), supported.end());

  std::vector<Hypothesis> hypotheses;
  for (const Pose3& start : starts) {
    if (!hypotheses.empty() && params.max_time_s > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count() >
            params.max_time_s) {
      break;
    }
    hypotheses.push_back(em.run(start));
  }
  const auto better = [](const Hypothesis& a, const Hypothesis& b) {
    return a.inliers != b.inliers ? a.inliers > b.inliers : a.trace.back() > b.trace.back();
  };
  const auto winner = std::min_element(hypotheses.begin(), hypotheses.end(), better);
  int runner_up = 0;
  for (const auto& h : hypotheses) {
    if (distinct(h.transform, winner->transform)) runner_up = std::max(runner_up, h.inliers);
  }

  result.transform = winner->transform;
  result.covariance = winner->covariance;
  result.weights = winner->weights;
  for (std::size_t k = 0; k < result.weights.size(); ++k)
    result.inliers[k] = result.weights[k] > 0.5;
  result.inlier_count = winner->inliers;
  result.runner_up_inliers = runner_up;
  result.log_likelihood = winner->trace.back();
  result.log_likelihood_trace = winner->trace;
  if (winner->inliers < params.min_inliers) {
    result.reason =
        std::to_string(winner->inliers) + " inliers, need " + std::to_string(params.min_inliers);
  } else if (winner->inliers < runner_up + params.min_inlier_margin) {
    result.reason = "ambiguous: " + std::to_string(winner->inliers) + " inliers against " +
                    std::to_string(runner_up) + " for another transform";
  } else {
    result.found = true;
  }
  return result;
}

AlignmentResult checkFrameTransform(const std::vector<AlignmentCandidate>& candidates,
                                    const AlignmentParams& params, const AlignmentResult& found) {
  validated(params);
  AlignmentResult result = found;
  const Prepared prepared = prepare(candidates, params);
  const Em em(candidates, params, prepared);
  result.log_likelihood = em.expectation(found.transform, &result.weights);
  result.log_likelihood_trace = {result.log_likelihood};
  result.inliers.assign(candidates.size(), false);
  for (std::size_t k = 0; k < result.weights.size(); ++k) {
    result.inliers[k] = result.weights[k] > 0.5;
  }
  result.inlier_count =
      static_cast<int>(std::count(result.inliers.begin(), result.inliers.end(), true));
  result.found = found.found && result.inlier_count >= params.min_inliers &&
                 result.inlier_count >= result.runner_up_inliers + params.min_inlier_margin;
  if (found.found && !result.found) {
    result.reason = std::to_string(result.inlier_count) + " inliers of the transform found before";
  }
  return result;
}

}  // namespace ccir_mapping::core::alignment
