// Gaussian mixtures, their EM fit and hierarchy (algorithms.md section 6.5): EM recovers a
// known mixture, the sampler's statistics, every level a valid mixture, the L2 distance.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ccir_mapping/core/hgmm/em_fitter.h"
#include "ccir_mapping/core/hgmm/hgmm.h"
#include "ccir_mapping/core/hgmm/mixture_codec.h"
#include "ccir_mapping/core/hgmm/mixture_registration.h"
#include "ccir_mapping/core/hgmm/novelty_keyframes.h"
#include "ccir_mapping/core/hgmm/scan_mixture.h"

namespace ccir_mapping::core::hgmm {
namespace {

Gaussian gaussian(double weight, const Eigen::Vector3d& mean, const Eigen::Vector3d& sigmas,
                  double yaw = 0.0) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return {weight, mean, r * sigmas.array().square().matrix().asDiagonal() * r.transpose()};
}

GaussianMixture knownMixture() {
  return GaussianMixture({gaussian(0.5, {0, 0, 0}, {1.0, 0.3, 0.2}, 0.5),
                          gaussian(0.3, {6, 1, 0}, {0.5, 0.5, 0.5}),
                          gaussian(0.2, {2, 7, 1}, {0.8, 0.2, 0.1}, -1.0)});
}

/// The known component nearest (Mahalanobis) to `mean`.
std::size_t nearest(const GaussianMixture& m, const Eigen::Vector3d& x) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < m.size(); ++k) {
    if (m.logComponentDensity(k, x) - std::log(m.components()[k].weight) >
        m.logComponentDensity(best, x) - std::log(m.components()[best].weight)) {
      best = k;
    }
  }
  return best;
}

TEST(EmFit, RecoversAKnownMixtureAndNeverLosesLikelihood) {
  const GaussianMixture truth = knownMixture();
  std::mt19937_64 rng(7);
  const Points points = truth.sample(30000, rng, 0.0);
  EmParams params;
  params.components = 3;
  params.covariance_floor_m2 = 1e-6;
  params.tolerance = 1e-7;
  params.max_points = 30000;  // all of them
  const EmFit fit = fitGaussianMixture(points, params);
  ASSERT_EQ(fit.mixture.size(), 3u);
  EXPECT_NEAR(fit.mixture.totalWeight(), 1.0, 1e-9);
  for (std::size_t i = 1; i < fit.log_likelihoods.size(); ++i) {
    EXPECT_GE(fit.log_likelihoods[i], fit.log_likelihoods[i - 1] - 1e-9) << "iteration " << i;
  }
  for (const Gaussian& estimate : fit.mixture.components()) {
    const Gaussian& real = truth.components()[nearest(truth, estimate.mean)];
    EXPECT_NEAR(estimate.weight, real.weight, 0.02);
    const double n = real.weight * 30000;
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(estimate.mean(a), real.mean(a), 4 * std::sqrt(real.covariance(a, a) / n));
    }
    const double scale = real.covariance.diagonal().maxCoeff();
    EXPECT_LT((estimate.covariance - real.covariance).cwiseAbs().maxCoeff(), 0.1 * scale)
        << estimate.covariance << "\n vs \n"
        << real.covariance;
  }
  // The fit explains the points about as well as the truth does, and says so itself.
  EXPECT_GT(fit.mixture.meanLogLikelihood(points), truth.meanLogLikelihood(points) - 0.01);
  EXPECT_NEAR(fit.mean_log_likelihood, fit.mixture.meanLogLikelihood(points), 1e-9);
}

TEST(EmFit, FewPointsAndDuplicatesGiveFewerComponentsNotNaNs) {
  Points points(3, 5);
  points.setZero();
  points(0, 4) = 1.0;
  EmParams params;  // 8 components asked, 2 distinct positions
  const EmFit fit = fitGaussianMixture(points, params);
  EXPECT_LE(fit.mixture.size(), 2u);
  EXPECT_TRUE(std::isfinite(fit.mixture.meanLogLikelihood(points)));
  EXPECT_THROW(fitGaussianMixture(Points(3, 0), params), std::invalid_argument);
  params.components = 0;
  EXPECT_THROW(fitGaussianMixture(points, params), std::invalid_argument);
}

TEST(GaussianMixture, SamplesHaveTheComponentsShareMeanAndCovariance) {
  const GaussianMixture truth = knownMixture();
  std::mt19937_64 rng(3);
  const std::size_t n = 60000;
  const Points samples = truth.sample(n, rng, 0.0);
  std::vector<std::vector<Eigen::Index>> of(truth.size());
  for (Eigen::Index i = 0; i < samples.cols(); ++i) of[nearest(truth, samples.col(i))].push_back(i);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const Gaussian& g = truth.components()[k];
    // The components overlap little: the share is within a few binomial deviations.
    EXPECT_NEAR(double(of[k].size()) / n, g.weight,
                4 * std::sqrt(g.weight * (1 - g.weight) / n) + 0.005);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Index i : of[k]) mean += samples.col(i);
    mean /= double(of[k].size());
    EXPECT_LT((mean - g.mean).norm(), 0.05);
  }
  // One component: covariance to a few percent.
  const GaussianMixture one({gaussian(1.0, {1, 2, 3}, {2.0, 1.0, 0.5}, 0.3)});
  const Points draws = one.sample(n, rng, 0.0);
  const Eigen::Vector3d mean = draws.rowwise().mean();
  const Points centred = draws.colwise() - mean;
  const Eigen::Matrix3d covariance = centred * centred.transpose() / double(n);
  EXPECT_LT((covariance - one.components()[0].covariance).cwiseAbs().maxCoeff(), 0.05 * 4.0);
  // The same seed, the same points; the gate keeps every draw within it.
  std::mt19937_64 a(11), b(11);
  EXPECT_TRUE(truth.sample(100, a).isApprox(truth.sample(100, b)));
  const Points gated = one.sample(5000, rng, 7.81);
  const Eigen::Matrix3d l = Eigen::LLT<Eigen::Matrix3d>(one.components()[0].covariance).matrixL();
  for (Eigen::Index i = 0; i < gated.cols(); ++i) {
    EXPECT_LE(l.triangularView<Eigen::Lower>()
                  .solve(gated.col(i) - one.components()[0].mean)
                  .squaredNorm(),
              7.81 + 1e-9);
  }
}

TEST(GaussianMixture, RefusesInvalidComponents) {
  Gaussian bad = gaussian(1.0, {0, 0, 0}, {1, 1, 1});
  bad.covariance(2, 2) = -1.0;
  EXPECT_THROW(GaussianMixture({bad}), std::invalid_argument);
  EXPECT_THROW(GaussianMixture({gaussian(-0.1, {0, 0, 0}, {1, 1, 1})}), std::invalid_argument);
  EXPECT_THROW(GaussianMixture({gaussian(0.0, {0, 0, 0}, {1, 1, 1})}), std::invalid_argument);
}

TEST(GaussianMixture, LogSumExpSkipsOnlyWhatCannotChangeTheSum) {
  Eigen::MatrixXd v(3, 3);
  v << 0.0, -1000.0, 5.0,  //
      -1.0, -1000.5, 5.0,  //
      -40.0, -2000.0, -700.0;
  const Eigen::RowVectorXd sums = logSumExpColumns(v);
  EXPECT_NEAR(sums(0), std::log(1.0 + std::exp(-1.0) + std::exp(-40.0)), 1e-15);
  EXPECT_NEAR(sums(1), -1000.0 + std::log(1.0 + std::exp(-0.5)), 1e-12);  // no underflow
  EXPECT_NEAR(sums(2), 5.0 + std::log(2.0), 1e-15);
  const Eigen::MatrixXd r = normalisedExp(v, sums);
  EXPECT_NEAR(r.col(1).sum(), 1.0, 1e-12);
  EXPECT_EQ(r(2, 0), 0.0);  // e^-40 of the column: below the double's epsilon
  EXPECT_NEAR(r(0, 2), 0.5, 1e-15);
}

TEST(L2Distance, ZeroForTheSameMixtureSymmetricAndAsMonteCarloSays) {
  const GaussianMixture f = knownMixture();
  const GaussianMixture g(
      {gaussian(0.6, {0.5, 0, 0}, {1.0, 0.4, 0.3}), gaussian(0.4, {5, 2, 0}, {0.7, 0.5, 0.5})});
  EXPECT_NEAR(l2Distance(f, f), 0.0, 1e-12);
  EXPECT_NEAR(innerProduct(f, f), innerProduct(f, GaussianMixture(f.components())), 1e-15);
  EXPECT_NEAR(l2Distance(f, g), l2Distance(g, f), 1e-12);
  EXPECT_GT(l2Distance(f, g), 0.0);
  // integral (f - g)^2 = E_f[f - g] - E_g[f - g].
  std::mt19937_64 rng(5);
  const std::size_t n = 200000;
  const Points from_f = f.sample(n, rng, 0.0), from_g = g.sample(n, rng, 0.0);
  double estimate = 0.0;
  for (Eigen::Index i = 0; i < Eigen::Index(n); ++i) {
    estimate += std::exp(f.logDensity(from_f.col(i))) - std::exp(g.logDensity(from_f.col(i)));
    estimate -= std::exp(f.logDensity(from_g.col(i))) - std::exp(g.logDensity(from_g.col(i)));
  }
  estimate /= double(n);
  EXPECT_NEAR(l2Distance(f, g), estimate, 0.05 * l2Distance(f, g));
}

TEST(Similarity, OneForTheSameMixtureFallingWithDistanceAndZeroWhenDisjoint) {
  const GaussianMixture f = knownMixture();
  const GaussianMixture g(
      {gaussian(0.6, {0.5, 0, 0}, {1.0, 0.4, 0.3}), gaussian(0.4, {5, 2, 0}, {0.7, 0.5, 0.5})});
  EXPECT_NEAR(similarity(f, f), 1.0, 1e-12);
  EXPECT_NEAR(similarity(f, g), similarity(g, f), 1e-12);
  EXPECT_NEAR(similarity(f, g), 1.0 - l2Distance(f, g) / (innerProduct(f, f) + innerProduct(g, g)),
              1e-12);
  double before = 1.0;
  for (const double shift_m : {0.3, 1.0, 3.0}) {
    const double s = similarity(f, transformed(f, Pose3(Eigen::Translation3d(shift_m, 0, 0))));
    EXPECT_LT(s, before) << shift_m;
    EXPECT_GT(s, 0.0) << shift_m;
    before = s;
  }
  EXPECT_EQ(similarity(f, transformed(f, Pose3(Eigen::Translation3d(1000, 0, 0)))), 0.0);
  EXPECT_EQ(similarity(f, GaussianMixture()), 0.0);
}

TEST(MixtureCodec, RoundTripIsCloseAndCorruptBytesAreRefused) {
  const GaussianMixture mixture = knownMixture();
  const std::vector<std::uint8_t> bytes = encodeMixture(mixture);
  EXPECT_EQ(bytes.size(), kMixtureHeaderBytes + 3 * kMixtureComponentBytes);
  const GaussianMixture decoded = decodeMixture(bytes);
  ASSERT_EQ(decoded.size(), mixture.size());
  for (std::size_t k = 0; k < mixture.size(); ++k) {
    const Gaussian& a = mixture.components()[k];
    const Gaussian& b = decoded.components()[k];
    EXPECT_NEAR(a.weight, b.weight, 1e-4);
    EXPECT_LT((a.mean - b.mean).cwiseAbs().maxCoeff(), 7.0 / 32767);  // half a step and float
    EXPECT_LT((a.covariance - b.covariance).norm(), 1e-3 * a.covariance.norm());
  }
  // The rounding changes the density far less than another mixture does.
  const GaussianMixture other({gaussian(1.0, {0.5, 0, 0}, {1.0, 0.4, 0.3})});
  EXPECT_LT(l2Distance(mixture, decoded), 1e-4 * l2Distance(mixture, other));

  std::vector<std::uint8_t> truncated(bytes.begin(), bytes.end() - 1);
  EXPECT_THROW(decodeMixture(truncated), std::invalid_argument);
  EXPECT_THROW(decodeMixture({}), std::invalid_argument);
  std::vector<std::uint8_t> version = bytes;
  version[0] = 9;
  EXPECT_THROW(decodeMixture(version), std::invalid_argument);
  std::vector<std::uint8_t> flat = bytes;
  flat[kMixtureHeaderBytes + 8] = flat[kMixtureHeaderBytes + 9] = 0;  // first factor diagonal 0
  EXPECT_THROW(decodeMixture(flat), std::invalid_argument);
}

/// Points on the walls and floor of a 12 x 8 m room with a 2 m pillar: planes, edges, corners.
Points room(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < 6000; ++i) {
    const double s = u(rng), t = u(rng);
    switch (i % 6) {
      case 0:
        out.emplace_back(12 * s, 0, 3 * t);
        break;
      case 1:
        out.emplace_back(12 * s, 8, 3 * t);
        break;
      case 2:
        out.emplace_back(0, 8 * s, 3 * t);
        break;
      case 3:
        out.emplace_back(12, 8 * s, 3 * t);
        break;
      case 4:
        out.emplace_back(12 * s, 8 * t, 0);
        break;
      default:
        out.emplace_back(5 + 2 * s, 3 + (t < 0.5 ? 0 : 2), 3 * u(rng));
        break;
    }
    out.back() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  Points points(3, Eigen::Index(out.size()));
  for (std::size_t i = 0; i < out.size(); ++i) points.col(Eigen::Index(i)) = out[i];
  return points;
}

TEST(Hgmm, EveryLevelIsAMixtureChildrenInsideParentsFinerLevelsFitBetter) {
  std::mt19937_64 rng(1);
  const Points points = room(rng);
  HgmmParams params;
  params.max_depth = 2;
  const Hgmm hgmm = Hgmm::build(points, params);
  ASSERT_GE(hgmm.depth(), 1) << "BIC kept no split of a room";
  std::size_t labelled = 0;  // EM ran on a subset of the 6000; every point still has a node
  for (const HgmmNode& node : hgmm.nodes()) labelled += node.depth == 0 ? node.points : 0;
  EXPECT_EQ(labelled, std::size_t(points.cols()));
  double previous_likelihood = -1e300;
  std::size_t previous_bytes = 0;
  for (int level = 0; level <= hgmm.depth(); ++level) {
    const GaussianMixture mixture = hgmm.level(level);
    EXPECT_NEAR(mixture.totalWeight(), 1.0, 1e-9) << "level " << level;
    EXPECT_GT(hgmm.bytes(level), previous_bytes);
    EXPECT_EQ(hgmm.bytes(level), encodeMixture(mixture).size());
    const double likelihood = mixture.meanLogLikelihood(points);
    EXPECT_GT(likelihood, previous_likelihood) << "level " << level;
    previous_likelihood = likelihood;
    previous_bytes = hgmm.bytes(level);
  }
  for (const HgmmNode& node : hgmm.nodes()) {
    if (node.parent < 0) continue;
    const Gaussian& parent = hgmm.nodes()[std::size_t(node.parent)].gaussian;
    const Eigen::Matrix3d l = Eigen::LLT<Eigen::Matrix3d>(parent.covariance).matrixL();
    const double d2 =
        l.triangularView<Eigen::Lower>().solve(node.gaussian.mean - parent.mean).squaredNorm();
    EXPECT_LE(d2, 9.0) << "a child's mean outside its parent's 3-sigma ellipsoid";
  }
  EXPECT_EQ(hgmm.levelWithin(hgmm.bytes(1)), 1);
  EXPECT_EQ(hgmm.levelWithin(hgmm.bytes(1) - 1), 0);
  EXPECT_FALSE(hgmm.levelWithin(hgmm.bytes(0) - 1).has_value());
}

TEST(Hgmm, ANodeThatIsOneGaussianIsNotSplit) {
  // Eight Gaussians 10 m apart: level 0 finds them; splitting one gains too little likelihood
  // for the 70 parameters its children cost (BIC), unlike the room's planes and edges.
  std::vector<Gaussian> blobs;
  for (int k = 0; k < 8; ++k) {
    blobs.push_back(gaussian(1.0 / 8, {10.0 * (k % 4), 10.0 * (k / 4), 0}, {1.0, 0.5, 0.3}, k));
  }
  std::mt19937_64 rng(2);
  const Points points = GaussianMixture(blobs).sample(8000, rng, 0.0);
  const Hgmm hgmm = Hgmm::build(points, HgmmParams{});
  EXPECT_EQ(hgmm.depth(), 0);
  EXPECT_EQ(hgmm.nodes().size(), 8u);
}

/// The room with a second pillar, so that no turn maps it onto itself.
Points asymmetricRoom(std::mt19937_64& rng) {
  Points points = room(rng);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Points pillar(3, 1500);
  for (Eigen::Index i = 0; i < pillar.cols(); ++i) {
    const double s = u(rng), t = 3 * u(rng);
    pillar.col(i) = i % 2 ? Eigen::Vector3d(9 + s, 6, t) : Eigen::Vector3d(9, 5 + s, t);
  }
  Points all(3, points.cols() + pillar.cols());
  all << points, pillar;
  return all;
}

double degrees(const Pose3& error) {
  return Eigen::AngleAxisd(error.linear()).angle() * 180 / M_PI;
}

TEST(MixtureRegistration, BothWaysRecoverAKnownTransformAndRefuseA90DegreeStart) {
  std::mt19937_64 rng(4);
  const Points target_points = asymmetricRoom(rng);
  // The source is the same room seen from a pose turned by 10 degrees and 0.5 m away.
  const Pose3 truth = Eigen::Translation3d(0.4, -0.3, 0.05) *
                      Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitZ());
  const Points source_points = truth.inverse() * target_points;
  HgmmParams params;
  const Hgmm target = Hgmm::build(target_points, params);
  const Hgmm source = Hgmm::build(source_points, params);
  RegistrationParams registration;
  const Registration mixtures = registerMixtures(
      source.level(source.depth()), target.level(target.depth()), Pose3::Identity(), registration);
  ASSERT_TRUE(mixtures.accepted) << mixtures.reason;
  EXPECT_GE(mixtures.similarity, registration.min_similarity);
  const Pose3 mixture_error = truth.inverse() * mixtures.transform;
  EXPECT_LT(mixture_error.translation().norm(), 0.01);
  EXPECT_LT(degrees(mixture_error), 0.2);
  const Registration sampled = registerSampled(source.level(source.depth()), target_points,
                                               Pose3::Identity(), registration, rng);
  ASSERT_TRUE(sampled.accepted) << sampled.reason;
  const Pose3 sampled_error = truth.inverse() * sampled.transform;
  EXPECT_LT(sampled_error.translation().norm(), 0.02);
  EXPECT_LT(degrees(sampled_error), 0.2);
  std::printf("mixtures: %.3f m %.2f deg; sampled: %.3f m %.2f deg\n",
              mixture_error.translation().norm(), degrees(mixture_error),
              sampled_error.translation().norm(), degrees(sampled_error));

  // Started 90 degrees off, neither claims a fit.
  const Pose3 wrong(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const Registration lost = registerMixtures(source.level(source.depth()),
                                             target.level(target.depth()), wrong, registration);
  const Registration lost_sampled =
      registerSampled(source.level(source.depth()), target_points, wrong, registration, rng);
  for (const Registration* r : {&lost, &lost_sampled}) {
    const Pose3 error = truth.inverse() * r->transform;
    std::printf("from 90 degrees: %s, fitness %.3f, similarity %.3f, error %.1f deg\n",
                r->accepted ? "accepted" : r->reason.c_str(), r->fitness_m2, r->similarity,
                degrees(error));
    if (r->accepted) {  // accepted only if it found its way back
      EXPECT_LT(degrees(error), 1.0) << "accepted a wrong alignment, fitness " << r->fitness_m2;
    } else {
      EXPECT_FALSE(r->reason.empty());
    }
  }
}

TEST(MixtureRegistration, TransformedMovesMeansAndTurnsCovariances) {
  const GaussianMixture m({gaussian(1.0, {1, 0, 0}, {2.0, 0.5, 0.1})});
  const Pose3 pose =
      Eigen::Translation3d(0, 0, 1) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  const Gaussian g = transformed(m, pose).components()[0];
  EXPECT_TRUE(g.mean.isApprox(Eigen::Vector3d(0, 1, 1), 1e-12));
  EXPECT_NEAR(g.covariance(1, 1), 4.0, 1e-12);  // the long axis now along y
  EXPECT_NEAR(g.covariance(0, 0), 0.25, 1e-12);
  RegistrationParams bad;
  bad.max_correspondence_m = 0;
  EXPECT_THROW(registerMixtures(m, m, Pose3::Identity(), bad), std::invalid_argument);
}

TEST(NoveltyKeyframes, ARevisitIsExplainedAndNewGroundIsStored) {
  std::mt19937_64 rng(6);
  const Points here = asymmetricRoom(rng);
  NoveltyKeyframes store{NoveltyParams{}};
  EXPECT_EQ(store.explainedShare(here, Pose3::Identity()), 0.0);
  ASSERT_TRUE(store.offer(here, Pose3::Identity()));
  EXPECT_GT(store.bytes(), 0u);
  // The same room seen again from 0.3 m further (another draw of its surfaces): explained.
  const Pose3 moved(Eigen::Translation3d(0.3, 0, 0));
  const Points again = moved.inverse() * asymmetricRoom(rng);
  EXPECT_GT(store.explainedShare(again, moved), 0.9);
  EXPECT_FALSE(store.offer(again, moved));
  // The same room 30 m away is new ground: stored, and then explained in its turn.
  const Pose3 far(Eigen::Translation3d(30, 0, 0));
  EXPECT_LT(store.explainedShare(here, far), 0.1);
  EXPECT_TRUE(store.offer(here, far));
  EXPECT_EQ(store.keyframes().size(), 2u);
  EXPECT_GT(store.explainedShare(here, far), 0.9);
  NoveltyParams bad;
  bad.min_explained_share = 2.0;
  EXPECT_THROW(NoveltyKeyframes{bad}, std::invalid_argument);
}

TEST(ScanMixture, FitsItsBudgetAndSamplesPointsOnTheSurfacesWithNormalsTowardsTheSensor) {
  std::mt19937_64 rng(5);
  // The room seen from its middle, 1.5 m above the floor.
  const Points points = room(rng).colwise() - Eigen::Vector3d(6.0, 4.0, 1.5);
  const auto bytes = encodeScanMixture(points, 4000);
  EXPECT_LE(bytes.size(), 4000U);
  const Hgmm model = Hgmm::build(points, HgmmParams{});
  EXPECT_EQ(decodeMixture(bytes).size(), model.components(*model.levelWithin(4000)));
  EXPECT_EQ(encodeScanMixture(points, model.bytes(0)).size(), model.bytes(0)) << "the root";
  EXPECT_THROW(encodeScanMixture(points, 100), std::invalid_argument) << "not even the root";
  EXPECT_THROW(encodeScanMixture(Points(3, 0), 4000), std::invalid_argument);

  const SampledScan scan = sampleScanMixture(bytes, 3000, 42);
  ASSERT_EQ(scan.points.cols(), 3000);
  ASSERT_EQ(scan.normals.cols(), 3000);
  double distance = 0.0;
  int floor = 0, floor_up = 0;
  for (Eigen::Index i = 0; i < scan.points.cols(); ++i) {
    const Eigen::Vector3d p = scan.points.col(i), n = scan.normals.col(i);
    distance += std::sqrt((points.colwise() - p).colwise().squaredNorm().minCoeff());
    EXPECT_NEAR(n.norm(), 1.0, 1e-9);
    EXPECT_LE(n.dot(p), 1e-9) << "faces the sensor";
    if (p.z() < -1.4 && std::abs(p.x()) < 5.0 && std::abs(p.y()) < 3.0) {
      ++floor;
      floor_up += n.z() > 0.9;
    }
  }
  // Within the gate, but a Gaussian over a 12 m wall reaches past its ends.
  EXPECT_LT(distance / 3000, 0.2) << "mean distance to the scan, m";
  ASSERT_GT(floor, 100);
  EXPECT_GT(floor_up, 0.9 * floor) << "the floor's samples point up";
  EXPECT_EQ(sampleScanMixture(bytes, 3000, 42).points, scan.points) << "seeded";
  EXPECT_NE(sampleScanMixture(bytes, 3000, 43).points, scan.points);
  auto truncated = bytes;
  truncated.pop_back();
  EXPECT_THROW(sampleScanMixture(truncated, 10, 1), std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core::hgmm
