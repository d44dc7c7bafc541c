#include "ccir_mapping/core/hgmm/mixture_registration.h"

#include <pcl/registration/gicp.h>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::hgmm {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Gicp = pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>;

Cloud::Ptr toCloud(const Points& points) {
  auto cloud = pcl::make_shared<Cloud>();
  cloud->reserve(static_cast<std::size_t>(points.cols()));
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    cloud->push_back(pcl::PointXYZ(float(points(0, i)), float(points(1, i)), float(points(2, i))));
  }
  return cloud;
}

Points means(const GaussianMixture& mixture) {
  Points out(3, static_cast<Eigen::Index>(mixture.size()));
  for (std::size_t k = 0; k < mixture.size(); ++k) {
    out.col(static_cast<Eigen::Index>(k)) = mixture.components()[k].mean;
  }
  return out;
}

Gicp::MatricesVectorPtr covariances(const GaussianMixture& mixture) {
  auto out = std::make_shared<Gicp::MatricesVector>();
  for (const Gaussian& g : mixture.components()) out->push_back(g.covariance);
  return out;
}

/// Runs `gicp` (inputs set) from `guess`; judged on convergence only.
Registration align(Gicp& gicp, const Pose3& guess, const RegistrationParams& params) {
  Registration result;
  // GICP needs its k = 20 neighbours for covariances it estimates, and PCL requires 4
  // correspondences at least.
  if (gicp.getInputSource()->size() < 4 || gicp.getInputTarget()->size() < 4) {
    result.reason = "fewer than 4 points or components on a side";
    return result;
  }
  gicp.setMaxCorrespondenceDistance(params.max_correspondence_m);
  gicp.setMaximumIterations(params.max_iterations);
  Cloud moved;
  gicp.align(moved, guess.matrix().cast<float>());
  result.transform = Pose3(gicp.getFinalTransformation().cast<double>());
  result.fitness_m2 = gicp.getFitnessScore(params.max_correspondence_m);
  result.accepted = gicp.hasConverged();
  if (!result.accepted) result.reason = "GICP did not converge";
  return result;
}

}  // namespace

std::vector<std::string> RegistrationParams::validate() const {
  ParamCheck check;
  check.inHalfOpenRange("max_correspondence_m", max_correspondence_m, 0.0, 100.0);
  check.inRange("max_iterations", max_iterations, 1, 10000);
  check.inHalfOpenRange("max_fitness_m2", max_fitness_m2, 0.0, 100.0);
  check.inRange("samples", samples, 10, 10000000);
  check.inRange("hgmm_min_similarity", min_similarity, 0.0, 1.0);
  return check.errors();
}

GaussianMixture transformed(const GaussianMixture& mixture, const Pose3& pose) {
  std::vector<Gaussian> components = mixture.components();
  for (Gaussian& g : components) {
    g.mean = pose * g.mean;
    g.covariance = pose.linear() * g.covariance * pose.linear().transpose();
    g.covariance = 0.5 * (g.covariance + g.covariance.transpose());
  }
  return GaussianMixture(std::move(components));
}

Registration registerMixtures(const GaussianMixture& source, const GaussianMixture& target,
                              const Pose3& guess, const RegistrationParams& params) {
  validated(params);
  Gicp gicp;
  gicp.setInputSource(toCloud(means(source)));
  gicp.setInputTarget(toCloud(means(target)));
  gicp.setSourceCovariances(covariances(source));
  gicp.setTargetCovariances(covariances(target));
  Registration result = align(gicp, guess, params);
  if (!result.accepted) return result;
  result.similarity = similarity(transformed(source, result.transform), target);
  if (!(result.similarity >= params.min_similarity)) {
    result.accepted = false;
    result.reason = "similarity " + std::to_string(result.similarity) + " below " +
                    std::to_string(params.min_similarity);
  }
  return result;
}

Registration registerSampled(const GaussianMixture& source, const Points& target,
                             const Pose3& guess, const RegistrationParams& params,
                             std::mt19937_64& rng) {
  validated(params);
  Gicp gicp;
  gicp.setInputSource(toCloud(source.sample(std::size_t(params.samples), rng)));
  gicp.setInputTarget(toCloud(target));
  Registration result = align(gicp, guess, params);
  if (result.accepted && !(result.fitness_m2 <= params.max_fitness_m2)) {
    result.accepted = false;
    result.reason = "fitness " + std::to_string(result.fitness_m2) + " m^2 above " +
                    std::to_string(params.max_fitness_m2);
  }
  return result;
}

}  // namespace ccir_mapping::core::hgmm
