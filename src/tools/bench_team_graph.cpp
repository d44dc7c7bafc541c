// bench_team_graph: the team pose graph on a simulated mission, against today's placement
// (teammates at their raw odometry poses moved by the EM transform) measured in the same run.
// Each robot's TeamGraph is fed, in mission time, its own keyframes, every teammate's keyframes
// (as fixed-rate sharing delivers them) and every inter-robot loop closure (those between two
// teammates as the one that found it shares it); it is optimised every --optimize-every-s. The
// closures stand in for the Matcher's verified ones: one per keyframe passing within
// --closure-radius-m of a teammate's, measured from the truth with noise; --false-fraction of them
// are replaced by false ones, in groups that agree with each other where "the mine repeats"
// (--false-mode grouped) or at random places (random). Prints JSON: per robot the ATE of every
// keyframe in its graph (own and teammates', after one rigid alignment to the truth), the
// team-transform errors, the accepted transforms, the optimisation times (p50 / p95 / max) and
// those of u_k over all own keyframes after each (p50 / p95 / the last).
// Needs no lidar: only the mission's odometry is recorded.
// --g2o-dir writes each robot's final team graph, which pgo_benchmark reads (--inter-robot).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/backend/team_graph.h"
#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/simulation/mission.h"
#include "ccir_mapping/core/testing/trajectory_error.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
using ccir_mapping::core::KeyframeId;
using ccir_mapping::core::Matrix6;
using ccir_mapping::core::Pose3;
using ccir_mapping::core::Stamp;
using ccir_mapping::core::backend::BackendParams;
using ccir_mapping::core::backend::BackendSnapshot;
using ccir_mapping::core::backend::TeamGraph;
using ccir_mapping::core::pose_graph::LoopClosureData;
namespace sim = ccir_mapping::core::simulation;

namespace {

struct Options {
  int seed = 21;
  int robots = 3;
  double duration_s = 300.0;
  double false_fraction = 0.0;
  std::string false_mode = "grouped";
  double closure_radius_m = 2.0;
  double noise_m = 0.05;
  double noise_deg = 0.5;
  double optimize_every_s = 10.0;
  /// Scales the simulator's odometry noise (0: exact odometry, as in the thesis's simulations).
  double odom_noise_scale = 1.0;
  /// Where each robot's final team graph is written (team_graph_<robot>.g2o), or "".
  std::string g2o_dir;
  BackendParams backend;
};

std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options("Usage: bench_team_graph [options]");
  options.add_options()("help", "print this help")(
      "seed", po::value<int>(&o->seed)->default_value(o->seed), "mission seed")(
      "robots", po::value<int>(&o->robots)->default_value(o->robots), "robots in the team")(
      "duration-s", po::value<double>(&o->duration_s)->default_value(o->duration_s),
      "mission length, s")("false-fraction",
                           po::value<double>(&o->false_fraction)->default_value(0.0),
                           "fraction of the inter-robot closures replaced by false ones [0, 1)")(
      "false-mode", po::value<std::string>(&o->false_mode)->default_value(o->false_mode),
      "grouped (groups of 5 agreeing with each other, each 5-15 keyframes off) | random")(
      "closure-radius-m", po::value<double>(&o->closure_radius_m)->default_value(2.0),
      "a closure where two robots' keyframes pass within this distance")(
      "noise-m", po::value<double>(&o->noise_m)->default_value(o->noise_m),
      "closure noise (std. dev.), m")("noise-deg",
                                      po::value<double>(&o->noise_deg)->default_value(o->noise_deg),
                                      "closure noise (std. dev.), deg")(
      "optimize-every-s", po::value<double>(&o->optimize_every_s)->default_value(10.0),
      "mission seconds between optimisations")(
      "odom-noise-scale", po::value<double>(&o->odom_noise_scale)->default_value(1.0),
      "scales the simulated odometry's noise (0: exact; the team transform is then observable "
      "to the closures' accuracy)")(
      "max-solve-time-s",
      po::value<double>(&o->backend.max_solve_time_s)->default_value(o->backend.max_solve_time_s),
      "the Backend's max_solve_time_s")(
      "solve-window-keyframes",
      po::value<int>(&o->backend.solve_window_keyframes)
          ->default_value(o->backend.solve_window_keyframes),
      "the Backend's solve_window_keyframes (0: every solve full)")(
      "full-solve-period-s",
      po::value<double>(&o->backend.full_solve_period_s)
          ->default_value(o->backend.full_solve_period_s),
      "the Backend's full_solve_period_s")(
      "g2o-dir", po::value<std::string>(&o->g2o_dir),
      "write each robot's final team graph there as team_graph_<robot>.g2o (robot-keyed ids, "
      "switch values)");
  if (const auto exit_code = tools::parseCommandLine("bench_team_graph", options, argc, argv)) {
    return exit_code;
  }
  if (o->false_fraction < 0.0 || o->false_fraction >= 1.0 ||
      (o->false_mode != "grouped" && o->false_mode != "random") || o->optimize_every_s <= 0.0 ||
      o->odom_noise_scale < 0.0 || !o->backend.validate().empty()) {
    return tools::usageError(
        "bench_team_graph",
        "need --false-fraction in [0, 1), --false-mode grouped | random, "
        "--optimize-every-s > 0, --odom-noise-scale >= 0, a valid --max-solve-time-s, "
        "--solve-window-keyframes and --full-solve-period-s");
  }
  return std::nullopt;
}

struct Keyframe {
  KeyframeId id;
  Stamp stamp;
  Pose3 odom;   // in the robot's odometry frame (its map frame's origin)
  Pose3 truth;  // in the world
};

/// Keyframes from the mission's odometry, chosen as the Preprocessor does, at the scan rate.
class KeyframeRecorder : public sim::RecordingSink {
 public:
  KeyframeRecorder(const Pose3& world_from_odom, std::vector<Keyframe>* out)
      : world_from_odom_(world_from_odom), out_(out) {}
  void odometry(const sim::OdometrySample& s) override {
    if (samples_++ % 5 != 0) return;  // 50 Hz odometry, 10 Hz scans
    const auto decision = selector_.offer(s.stamp, s.odometry);
    if (decision.outcome != ccir_mapping::core::preprocess::KeyframeSelector::Outcome::kKeyframe) {
      return;
    }
    out_->push_back({decision.id, s.stamp, s.odometry, world_from_odom_ * s.truth});
  }
  void scan(const ccir_mapping::core::LidarScan&, Stamp) override {}

 private:
  Pose3 world_from_odom_;
  std::vector<Keyframe>* out_;
  ccir_mapping::core::preprocess::KeyframeSelector selector_{{}};
  long samples_ = 0;
};

/// An inter-robot closure: robot a's keyframe sees robot b's at `relative` (a's frame).
struct Closure {
  std::size_t a, b;
  KeyframeId ka, kb;
  Pose3 relative;
  Stamp stamp;  // when both keyframes exist
  bool false_one = false;

  /// As the robot that found it sends it (each of the pair finds about half).
  LoopClosureData loop(const Matrix6& covariance, bool found_by_a) const {
    LoopClosureData l;
    const auto name = [](std::size_t i) { return sim::Mission::robotName(static_cast<int>(i)); };
    l.robot_from = name(found_by_a ? a : b);
    l.robot_to = name(found_by_a ? b : a);
    l.keyframe_from = found_by_a ? ka : kb;
    l.keyframe_to = found_by_a ? kb : ka;
    l.relative = found_by_a ? relative : relative.inverse();
    l.covariance = covariance;
    return l;
  }
};

Pose3 noisy(const Pose3& pose, double sigma_m, double sigma_rad, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Pose3 noise = Pose3::Identity();
  noise.translation() = Eigen::Vector3d(n(rng), n(rng), n(rng)) * sigma_m;
  noise.linear() = (Eigen::AngleAxisd(n(rng) * sigma_rad, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(n(rng) * sigma_rad, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(n(rng) * sigma_rad, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
  return pose * noise;
}

std::vector<Closure> makeClosures(const Options& o, const std::vector<std::vector<Keyframe>>& kf) {
  std::mt19937_64 rng(static_cast<std::uint64_t>(o.seed) * 7919 + 1);
  std::vector<Closure> closures;
  for (std::size_t a = 0; a < kf.size(); ++a) {
    for (std::size_t b = a + 1; b < kf.size(); ++b) {
      for (const auto& k : kf[b]) {  // b's keyframe, nearest of a's within the radius
        const Keyframe* best = nullptr;
        double best_d = o.closure_radius_m;
        for (const auto& j : kf[a]) {
          const double d = (j.truth.translation() - k.truth.translation()).norm();
          if (d < best_d) best_d = d, best = &j;
        }
        if (!best) continue;
        closures.push_back(
            {a, b, best->id, k.id,
             noisy(best->truth.inverse() * k.truth, o.noise_m, o.noise_deg * M_PI / 180, rng),
             std::max(best->stamp, k.stamp)});
      }
    }
  }
  // False ones replace a fraction of them: the same measurement, to another keyframe of b.
  // Grouped: 5 consecutive closures of a pair (consecutive keyframes of b), all shifted by the
  // same 5-15 keyframes: a stretch of the mine that looks like another and agrees with itself.
  std::vector<std::size_t> order(closures.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  const auto wanted = static_cast<std::size_t>(o.false_fraction * closures.size());
  const bool grouped = o.false_mode == "grouped";
  std::size_t made = 0;
  for (std::size_t i = 0; i < order.size() && made < wanted; ++i) {
    const int offset = (rng() % 2 ? 1 : -1) * static_cast<int>(5 + rng() % 11);
    for (std::size_t g = 0; g < (grouped ? 5U : 1U) && made < wanted; ++g) {
      Closure& c = closures[(order[i] + g) % closures.size()];
      const auto count = static_cast<long>(kf[c.b].size());
      const long target = grouped ? static_cast<long>(c.kb) + offset
                                  : static_cast<long>(rng() % static_cast<unsigned long>(count));
      if (c.false_one || target < 0 || target >= count || target == static_cast<long>(c.kb)) {
        continue;
      }
      c.kb = static_cast<KeyframeId>(target);
      c.stamp = std::max(c.stamp, kf[c.b][static_cast<std::size_t>(target)].stamp);
      c.false_one = true;
      ++made;
    }
  }
  std::stable_sort(closures.begin(), closures.end(),
                   [](const Closure& x, const Closure& y) { return x.stamp < y.stamp; });
  return closures;
}

struct PeerError {
  std::string peer;
  double translation_m = 0.0;
  double yaw_deg = 0.0;
};

/// One robot's graph (team graph or today's placement) at the end of the mission.
struct Outcome {
  double ate_m = 0.0;
  std::size_t keyframes = 0;
  std::vector<PeerError> transforms;  // of the teammates whose transform it accepted
  int inter_loops = 0, inter_loops_rejected = 0;
  /// Mean over every optimisation of the ATE of the robot's own keyframes as it stood then: what
  /// the robot lived with, windowed solves included.
  double ate_along_m = 0.0;
};

/// ATE of the own keyframes of snapshot `s` of robot r.
double ownAte(const BackendSnapshot& s, std::size_t r,
              const std::vector<std::vector<Keyframe>>& kf) {
  std::vector<Pose3> truth;
  for (const KeyframeId id : s.ids) truth.push_back(kf[r][id].truth);
  return ccir_mapping::core::testing::absoluteTrajectoryError(s.poses, truth);
}

struct Results {
  std::size_t keyframes = 0, closures = 0, false_closures = 0;
  std::vector<std::string> robots;
  std::vector<Outcome> graph, baseline;
  std::vector<double> solve_s_graph, solve_s_baseline;
  std::vector<double> uncertainty_s;         // the team graph's u_k of all own keyframes, per solve
  int windowed_solves = 0, full_solves = 0;  // the team graph's
};

double yawOf(const Pose3& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

/// ATE and transform errors of robot r's final snapshot: own keyframes at their optimised poses;
/// teammates the team graph holds at its poses (`in_graph`), or at their odometry poses moved by
/// the EM transform (today's placement) for the teammates `placed` names.
Outcome evaluate(const BackendSnapshot& s, std::size_t r,
                 const std::vector<std::vector<Keyframe>>& kf, const sim::Mission& mission,
                 const std::vector<std::string>& placed) {
  Outcome out;
  std::vector<Pose3> estimate, truth;
  for (std::size_t k = 0; k < s.ids.size(); ++k) {
    estimate.push_back(s.poses[k]);
    truth.push_back(kf[r][s.ids[k]].truth);
  }
  const auto index = [](const std::string& name) {
    int i = 0;
    while (sim::Mission::robotName(i) != name) ++i;
    return static_cast<std::size_t>(i);
  };
  const Pose3 odom_r = mission.robots()[r].world_from_odom;
  for (const auto& estimate_of : s.team) {
    if (std::find(placed.begin(), placed.end(), estimate_of.peer) == placed.end()) continue;
    const std::size_t p = index(estimate_of.peer);
    const Pose3 transform = estimate_of.alignment.transform;
    const Pose3 error =
        (odom_r.inverse() * mission.robots()[p].world_from_odom).inverse() * transform;
    out.transforms.push_back(
        {estimate_of.peer, error.translation().norm(), std::abs(yawOf(error)) * 180 / M_PI});
    if (estimate_of.in_graph) {
      for (const auto& peer : s.peer_keyframes) {
        if (peer.robot != estimate_of.peer) continue;
        for (std::size_t k = 0; k < peer.ids.size(); ++k) {
          estimate.push_back(peer.poses[k]);
          truth.push_back(kf[p][peer.ids[k]].truth);
        }
      }
    } else {
      for (const auto& keyframe : kf[p]) {
        estimate.push_back(transform * keyframe.odom);
        truth.push_back(keyframe.truth);
      }
    }
  }
  out.keyframes = estimate.size();
  out.ate_m = ccir_mapping::core::testing::absoluteTrajectoryError(estimate, truth);
  out.inter_loops = s.loops.inter;
  out.inter_loops_rejected = s.loops.inter_rejected;
  return out;
}

Results run(const Options& o) {
  sim::MissionParams mission_params;
  mission_params.seed = o.seed;
  mission_params.robots = o.robots;
  mission_params.duration_s = o.duration_s;
  auto& odometry = mission_params.odometry;
  odometry.odom_noise_m_per_m *= o.odom_noise_scale;
  odometry.odom_noise_rad_per_m *= o.odom_noise_scale;
  odometry.odom_noise_rad_per_rad *= o.odom_noise_scale;
  const sim::Mission mission(mission_params);
  std::vector<std::vector<Keyframe>> kf(static_cast<std::size_t>(o.robots));
  Results r;
  for (int i = 0; i < o.robots; ++i) {
    KeyframeRecorder recorder(mission.robots()[static_cast<std::size_t>(i)].world_from_odom,
                              &kf[static_cast<std::size_t>(i)]);
    mission.record(i, recorder, /*scans=*/false);
    r.keyframes += kf[static_cast<std::size_t>(i)].size();
    r.robots.push_back(sim::Mission::robotName(i));
  }
  const std::vector<Closure> closures = makeClosures(o, kf);
  r.closures = closures.size();
  for (const auto& c : closures) r.false_closures += c.false_one;
  const double sigma_rad = o.noise_deg * M_PI / 180;
  Matrix6 covariance = Matrix6::Identity() * o.noise_m * o.noise_m;
  covariance.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma_rad * sigma_rad;

  BackendParams today = o.backend;
  today.team_graph = false;
  for (std::size_t robot = 0; robot < kf.size(); ++robot) {
    const std::string name = r.robots[robot];
    TeamGraph graph(name, o.backend);
    TeamGraph baseline(name, today);
    std::vector<std::size_t> next(kf.size(), 0);
    std::size_t next_closure = 0;
    BackendSnapshot last_graph, last_baseline;
    double ate_sum[2] = {0.0, 0.0};
    int ate_count = 0;
    for (Stamp t = mission.startStamp();;
         t += ccir_mapping::core::fromSeconds(o.optimize_every_s)) {
      const Stamp now = std::min(t, mission.endStamp());
      for (std::size_t i = 0; i < kf.size(); ++i) {
        for (; next[i] < kf[i].size() && kf[i][next[i]].stamp <= now; ++next[i]) {
          const Keyframe& k = kf[i][next[i]];
          for (TeamGraph* g : {&graph, &baseline}) {
            if (i == robot)
              g->addKeyframe(k.id, k.stamp, k.odom);
            else
              g->addPeerKeyframe(r.robots[i], k.id, k.odom);
          }
        }
      }
      for (; next_closure < closures.size() && closures[next_closure].stamp <= now;
           ++next_closure) {
        const Closure& c = closures[next_closure];
        const LoopClosureData loop = c.loop(covariance, next_closure % 2 == 0);
        graph.addLoopClosure(loop);
        baseline.addLoopClosure(loop);
      }
      last_graph = graph.optimize();
      last_baseline = baseline.optimize();
      r.solve_s_graph.push_back(last_graph.solve_s);
      r.windowed_solves += last_graph.solved == BackendSnapshot::Solve::kWindow;
      r.full_solves += last_graph.solved == BackendSnapshot::Solve::kFull;
      r.solve_s_baseline.push_back(last_baseline.solve_s);
      if (last_graph.ids.size() > 1) {
        const auto start = std::chrono::steady_clock::now();
        if (!graph.positionVariances(last_graph.ids)) throw std::runtime_error("no u_k");
        r.uncertainty_s.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        ate_sum[0] += ownAte(last_graph, robot, kf);
        ate_sum[1] += ownAte(last_baseline, robot, kf);
        ++ate_count;
      }
      if (now == mission.endStamp()) break;
    }
    // Compared on the same keyframes: teammates both accepted.
    std::vector<std::string> both;
    for (const auto& e : last_graph.team) {
      for (const auto& b : last_baseline.team) {
        if (e.peer == b.peer && e.alignment.found && b.alignment.found) both.push_back(e.peer);
      }
    }
    if (!o.g2o_dir.empty()) {
      const std::string path = o.g2o_dir + "/team_graph_" + name + ".g2o";
      graph.saveG2o(path);
      std::fprintf(stderr, "bench_team_graph: wrote %s\n", path.c_str());
    }
    r.graph.push_back(evaluate(last_graph, robot, kf, mission, both));
    r.baseline.push_back(evaluate(last_baseline, robot, kf, mission, both));
    r.graph.back().ate_along_m = ate_sum[0] / std::max(ate_count, 1);
    r.baseline.back().ate_along_m = ate_sum[1] / std::max(ate_count, 1);
    std::fprintf(stderr, "bench_team_graph: %s done\n", name.c_str());
  }
  return r;
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(q * static_cast<double>(values.size() - 1) + 0.5)];
}

std::string outcomeJson(const Outcome& o) {
  std::string transforms;
  for (const auto& t : o.transforms) {
    char buffer[160];
    std::snprintf(buffer, sizeof buffer,
                  "%s{\"peer\": \"%s\", \"error_m\": %.4f, \"error_deg\": %.3f}",
                  transforms.empty() ? "" : ", ", t.peer.c_str(), t.translation_m, t.yaw_deg);
    transforms += buffer;
  }
  char buffer[512];
  std::snprintf(buffer, sizeof buffer,
                "{\"ate_m\": %.4f, \"ate_along_m\": %.4f, \"keyframes\": %zu, \"inter_loops\": %d, "
                "\"inter_loops_rejected\": %d, \"transforms\": [%s]}",
                o.ate_m, o.ate_along_m, o.keyframes, o.inter_loops, o.inter_loops_rejected,
                transforms.c_str());
  return buffer;
}

void report(const Options& o, const Results& r) {
  std::printf(
      "{\n  \"benchmark\": \"team_graph\",\n  \"seed\": %d,\n  \"robots\": %d,\n"
      "  \"duration_s\": %.0f,\n  \"keyframes\": %zu,\n  \"closures\": %zu,\n"
      "  \"false_closures\": %zu,\n  \"false_mode\": \"%s\",\n"
      "  \"max_solve_time_s\": %.3f,\n  \"odom_noise_scale\": %.2f,\n"
      "  \"solve_window_keyframes\": %d,\n  \"full_solve_period_s\": %.1f,\n",
      o.seed, o.robots, o.duration_s, r.keyframes, r.closures, r.false_closures,
      o.false_mode.c_str(), o.backend.max_solve_time_s, o.odom_noise_scale,
      o.backend.solve_window_keyframes, o.backend.full_solve_period_s);
  double worst_ratio = 0.0;
  std::printf("  \"per_robot\": [\n");
  for (std::size_t i = 0; i < r.robots.size(); ++i) {
    const double ratio = r.baseline[i].ate_m > 0 ? r.graph[i].ate_m / r.baseline[i].ate_m : 0.0;
    worst_ratio = std::max(worst_ratio, ratio);
    std::printf(
        "    {\"robot\": \"%s\", \"ate_ratio\": %.3f,\n     \"team_graph\": %s,\n"
        "     \"today\": %s}%s\n",
        r.robots[i].c_str(), ratio, outcomeJson(r.graph[i]).c_str(),
        outcomeJson(r.baseline[i]).c_str(), i + 1 < r.robots.size() ? "," : "");
  }
  std::printf("  ],\n  \"worst_ate_ratio\": %.3f,\n", worst_ratio);
  std::printf(
      "  \"optimisation_s\": {\"team_graph\": {\"runs\": %zu, \"windowed\": %d, \"full\": %d, "
      "\"p50\": %.3f, "
      "\"p95\": %.3f, \"max\": %.3f}, \"today\": {\"p50\": %.3f, \"p95\": %.3f, "
      "\"max\": %.3f}},\n",
      r.solve_s_graph.size(), r.windowed_solves, r.full_solves, percentile(r.solve_s_graph, 0.5),
      percentile(r.solve_s_graph, 0.95), percentile(r.solve_s_graph, 1.0),
      percentile(r.solve_s_baseline, 0.5), percentile(r.solve_s_baseline, 0.95),
      percentile(r.solve_s_baseline, 1.0));
  std::printf("  \"uncertainty_s\": {\"p50\": %.3f, \"p95\": %.3f, \"last\": %.3f}\n}\n",
              percentile(r.uncertainty_s, 0.5), percentile(r.uncertainty_s, 0.95),
              r.uncertainty_s.empty() ? 0.0 : r.uncertainty_s.back());
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool<Options>("bench_team_graph", argc, argv, parse, run, report);
}
