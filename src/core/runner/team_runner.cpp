#include "ccir_mapping/core/runner/team_runner.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <thread>
#include <tuple>

#include <unistd.h>

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/runner/keyframe_feed.h"
#include "ccir_mapping/core/runner/robot_pipeline.h"
#include "ccir_mapping/core/runner/team_link.h"
#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::runner {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
/// Radio-range links are re-evaluated this often (mission seconds).
constexpr double kTopologyPeriodS = 1.0;

std::uint64_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

double processCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Calls f(0) .. f(n - 1) on up to `threads` threads; rethrows the first exception.
template <class F>
void forEachRobot(int n, int threads, const F& f) {
  if (threads <= 1 || n <= 1) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<int> next{0};
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(n));
  const auto work = [&] {
    for (int i = next++; i < n; i = next++) {
      try {
        f(i);
      } catch (...) {
        errors[static_cast<std::size_t>(i)] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::min(threads, n); ++t) pool.emplace_back(work);
  for (auto& thread : pool) thread.join();
  for (const auto& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

TransformSample compare(double t_s, const alignment::AlignmentResult& estimate,
                        const Pose3& truth) {
  TransformSample s;
  s.t_s = t_s;
  s.valid = estimate.found;
  s.inliers = estimate.inlier_count;
  if (!s.valid) return s;
  const Pose3 error = truth.inverse() * estimate.transform;
  s.error_m = (estimate.transform.translation() - truth.translation()).norm();
  s.error_deg = Eigen::AngleAxisd(error.rotation()).angle() * 180.0 / M_PI;
  return s;
}

double rms(const std::vector<double>& squares) {
  if (squares.empty()) return 0.0;
  double sum = 0.0;
  for (const double s : squares) sum += s;
  return std::sqrt(sum / static_cast<double>(squares.size()));
}

/// A message on its way to a robot: when it arrives, and an order that breaks ties the same way
/// on every run.
struct Inbound {
  double arrival_s;
  int sender;
  std::uint64_t order;
  TeamMessage message;
};

struct KeyframeRecord {
  Pose3 odom;
  Pose3 truth;
};

}  // namespace

TeamRunner::TeamRunner(const RunnerParams& params,
                       std::shared_ptr<const place_recognition::PlaceModel> model, int threads)
    : params_(params), model_(std::move(model)), threads_(std::max(1, threads)) {
  const auto errors = params_.validate();
  if (!errors.empty()) throw std::invalid_argument(errors.front());
  if (!model_) throw std::invalid_argument("model: no place-recognition model");
}

TeamResult TeamRunner::run(const Progress& progress) {
  const auto wall_start = std::chrono::steady_clock::now();
  const double cpu_start = processCpuSeconds();
  const simulation::Mission mission(params_.mission);
  const int n = params_.mission.robots;
  const double start_s = toSeconds(mission.startStamp());
  const double end_s = toSeconds(mission.endStamp());
  const auto& plans = mission.robots();

  std::vector<std::string> names;
  for (int i = 0; i < n; ++i) names.push_back(simulation::Mission::robotName(i));
  std::vector<std::unique_ptr<RobotPipeline>> robots;
  std::vector<std::unique_ptr<KeyframeFeed>> feeds;
  // Each robot's timers tick at a phase of their own (drawn from the seed), as on separate
  // masters: whether an offer is answered before the next one supersedes it depends on it.
  std::mt19937_64 phases(static_cast<std::uint64_t>(params_.mission.seed) * 7919U + 17U);
  for (int i = 0; i < n; ++i) {
    std::vector<std::string> peers = names;
    peers.erase(peers.begin() + i);
    const double phase = std::uniform_real_distribution<double>(0.0, 1.0)(phases);
    robots.push_back(
        std::make_unique<RobotPipeline>(names[i], peers, params_, model_, start_s, phase));
  }
  for (int i = 0; i < n; ++i) {
    feeds.push_back(std::make_unique<KeyframeFeed>(mission, i, params_.preprocessor));
  }

  // Links, made when first used; each sender's share its total budget.
  std::vector<std::shared_ptr<transport::TokenBucket>> totals;
  for (int i = 0; i < n; ++i) {
    totals.push_back(std::make_shared<transport::TokenBucket>(
        params_.bridge.total_budget_bytes_per_s, params_.bridge.burst_bytes, start_s));
  }
  std::vector<std::map<int, std::unique_ptr<TeamLink>>> links(static_cast<std::size_t>(n));
  const auto link = [&](int i, int j) -> TeamLink& {
    auto& l = links[i][j];
    if (!l) {
      testing::LinkEmulatorParams radio = params_.radio;
      radio.seed = params_.radio.seed * 1000003ULL + static_cast<std::uint64_t>(i * n + j);
      l = std::make_unique<TeamLink>(params_.bridge, radio, totals[i], start_s);
    }
    return *l;
  };

  // Which pairs are linked.
  std::vector<std::vector<char>> up(n, std::vector<char>(n, 1));
  for (int i = 0; i < n; ++i) up[i][i] = 0;
  const auto positionAt = [&](int i, double t_s) {
    const auto& plan = plans[i];
    const double since = std::max(0.0, t_s - start_s - plan.start_offset_s);
    return Eigen::Vector3d((plan.trajectory.poseAt(since) * mission.sensorMount()).translation());
  };
  const auto updateTopology = [&](double t_s) {
    if (params_.topology == Topology::kAllPairs) return;
    std::vector<Eigen::Vector3d> at;
    for (int i = 0; i < n; ++i) at.push_back(positionAt(i, t_s));
    // Pairs in range, nearest first, each taken while both have fewer than max_peers links.
    std::vector<std::tuple<double, int, int>> in_range;
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        const double d = (at[j] - at[i]).norm();
        if (d > params_.radio_range_m) continue;
        if (params_.radio_needs_line_of_sight && d > 1e-6 &&
            mission.world().castRay({at[i], (at[j] - at[i]) / d}, d)) {
          continue;
        }
        in_range.emplace_back(d, i, j);
      }
    }
    std::sort(in_range.begin(), in_range.end());
    std::vector<int> degree(n, 0);
    for (auto& row : up) std::fill(row.begin(), row.end(), 0);
    for (const auto& [d, i, j] : in_range) {
      if (params_.max_peers > 0 &&
          (degree[i] >= params_.max_peers || degree[j] >= params_.max_peers)) {
        continue;
      }
      up[i][j] = up[j][i] = 1;
      ++degree[i];
      ++degree[j];
    }
  };

  TeamResult result;
  result.robots.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) result.robots[i].name = names[i];
  std::vector<std::vector<Inbound>> inbox(static_cast<std::size_t>(n));
  std::vector<std::vector<std::pair<int, Delivery>>> delivered(static_cast<std::size_t>(n));
  std::vector<std::map<KeyframeId, KeyframeRecord>> keyframes(static_cast<std::size_t>(n));
  const auto truthOf = [&](int i, int j) {
    return Pose3(plans[i].world_from_odom.inverse() * plans[j].world_from_odom);
  };

  const double step = params_.step_s;
  double next_stats = start_s, next_series = start_s, next_topology = start_s;
  std::uint64_t order = 0;
  for (double t0 = start_s; t0 < end_s - 1e-9; t0 += step) {
    // The last step (t0 accumulates rounding, hence the margin) ends at end_s and takes every
    // keyframe left: the mission's last scan is published as it ends, and a bag holds it too.
    const bool last = t0 + step >= end_s - 1e-9;
    const double t1 = last ? end_s : t0 + step;
    if (t0 >= next_topology) {
      updateTopology(t0);
      next_topology += kTopologyPeriodS;
    }
    const bool stats_due = t0 >= next_stats;
    if (stats_due) next_stats += params_.bridge.stats_period_s;

    // Each robot handles its step.
    forEachRobot(n, threads_, [&](int i) {
      const double cpu0 = threadCpuSeconds();
      RobotPipeline& robot = *robots[i];
      if (stats_due) {
        for (int j = 0; j < n; ++j) {  // a link never made is one never up: the default
          if (j != i && (up[i][j] || links[i].count(j))) {
            robot.setLink(names[j], link(i, j).state(up[i][j], t0));
          }
        }
      }
      robot.runTimers(t0);
      const auto frames = feeds[i]->takeUntil(last ? kInfinity : t1);
      auto& messages = inbox[i];
      std::size_t k = 0, m = 0;
      while (k < frames.size() || (m < messages.size() && messages[m].arrival_s < t1)) {
        const double message_at =
            m < messages.size() && messages[m].arrival_s < t1 ? messages[m].arrival_s : kInfinity;
        if (k < frames.size() && frames[k].published_s <= message_at) {
          keyframes[i][frames[k].decision.id] = {frames[k].odom_pose, frames[k].true_pose};
          robot.onKeyframe(std::max(t0, frames[k].published_s), frames[k]);
          ++k;
        } else {
          robot.onMessage(std::max(t0, message_at), messages[m].message);
          ++m;
        }
      }
      messages.erase(messages.begin(), messages.begin() + static_cast<std::ptrdiff_t>(m));
      result.robots[i].pipeline_cpu_s += threadCpuSeconds() - cpu0;
    });

    // Each robot's outbox goes onto its links.
    forEachRobot(n, threads_, [&](int i) {
      const auto out = robots[i]->takeOutbox();
      auto& arrived = delivered[i];
      std::size_t k = 0;
      double now = t0;
      const auto enqueue = [&](const RobotPipeline::Outgoing& o) {
        for (int j = 0; j < n; ++j) {
          const bool addressed = o.peer.empty() ? up[i][j] != 0 : o.peer == names[j];
          if (j != i && addressed) link(i, j).enqueue(o.message, now);
        }
      };
      while (true) {
        const double enqueue_at = k < out.size() ? std::max(out[k].time_s, now) : kInfinity;
        double send_at = kInfinity;
        int best = -1;
        for (auto& [j, l] : links[i]) {
          if (!up[i][j]) continue;
          const double at = now + l->delay(now);
          if (at < send_at) send_at = at, best = j;
        }
        if (std::min(enqueue_at, send_at) >= t1) break;
        if (enqueue_at <= send_at) {
          now = enqueue_at;
          enqueue(out[k++]);
          continue;
        }
        now = send_at;
        std::optional<Delivery> done;
        if (!links[i][best]->sendNext(now, &done)) {
          now += 1e-6;  // the bucket's rounding: the frame leaves a moment later
        } else if (done) {
          arrived.emplace_back(best, std::move(*done));
        }
      }
      for (; k < out.size(); ++k) enqueue(out[k]);
    });

    // Deliveries reach their robots' inboxes (handled from the next step on).
    for (int i = 0; i < n; ++i) {
      for (auto& [j, d] : delivered[i]) {
        inbox[j].push_back({d.arrival_s, i, order++, std::move(d.message)});
      }
      delivered[i].clear();
    }
    for (auto& messages : inbox) {
      std::sort(messages.begin(), messages.end(), [](const Inbound& a, const Inbound& b) {
        return std::tie(a.arrival_s, a.sender, a.order) < std::tie(b.arrival_s, b.sender, b.order);
      });
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        if (up[i][j]) result.link_up_s[names[i] + "->" + names[j]] += t1 - t0;
      }
    }

    if (t1 >= next_series || t1 >= end_s - 1e-9) {
      next_series += params_.series_period_s;
      const double t = t1 - start_s;
      for (int i = 0; i < n; ++i) {
        RobotResult& r = result.robots[i];
        for (const auto& [j, l] : links[i]) {
          r.bytes_series[names[j]].emplace_back(t, l->counters().bytes_sent);
        }
        const auto stats = robots[i]->mapStats();
        r.map_series.push_back({t, stats.known_volume_m3, stats.entropy_bits});
        r.cpu_series.emplace_back(t, r.pipeline_cpu_s + feeds[i]->cpuSeconds());
        r.work_series.push_back({t, keyframes[i].size(), robots[i]->places(),
                                 robots[i]->verifications(), robots[i]->stageCpu()});
        for (const auto& estimate : robots[i]->snapshot().team) {
          const int j = static_cast<int>(std::find(names.begin(), names.end(), estimate.peer) -
                                         names.begin());
          r.transform_series[estimate.peer].push_back(
              compare(t, estimate.alignment, truthOf(i, j)));
        }
      }
      result.memory_series.emplace_back(t, residentBytes());
    }
    if (progress) {
      progress(
          t1 - start_s, end_s - start_s,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
    }
  }

  // What each robot ended with.
  for (int i = 0; i < n; ++i) {
    RobotResult& r = result.robots[i];
    const RobotPipeline& robot = *robots[i];
    r.keyframes = keyframes[i].size();
    r.recording_cpu_s = feeds[i]->cpuSeconds();
    r.stage_cpu_s = robot.stageCpu();
    r.closure_waits = robot.closureWaits();
    r.dropped_scans = feeds[i]->droppedScans();
    r.own_loops = robot.ownLoops();
    r.inter_robot_loops = robot.interRobotLoops();
    r.map = robot.mapStats();
    r.broker = robot.brokerReport();
    r.refusals = robot.refusals();
    for (const auto& [j, l] : links[i]) r.links[names[j]] = l->counters();
    const auto& snapshot = robot.snapshot();
    r.team = snapshot.team;
    for (const auto& estimate : snapshot.team) {
      const int j =
          static_cast<int>(std::find(names.begin(), names.end(), estimate.peer) - names.begin());
      r.transforms[estimate.peer] = compare(end_s - start_s, estimate.alignment, truthOf(i, j));
    }
    std::vector<double> optimised, odometry;
    for (std::size_t k = 0; k < snapshot.ids.size(); ++k) {
      const auto it = keyframes[i].find(snapshot.ids[k]);
      if (it == keyframes[i].end()) continue;
      const Eigen::Vector3d truth = it->second.truth.translation();
      optimised.push_back((snapshot.poses[k].translation() - truth).squaredNorm());
      odometry.push_back((it->second.odom.translation() - truth).squaredNorm());
    }
    r.ate_m = rms(optimised);
    r.odometry_ate_m = rms(odometry);
  }
  result.duration_s = end_s - start_s;
  result.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  result.cpu_s = processCpuSeconds() - cpu_start;
  return result;
}

}  // namespace ccir_mapping::core::runner
