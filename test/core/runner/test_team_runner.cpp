// The team in simulated time (core/runner): a link's frames keep the Bridge's rules, and a short
// run is the same for any thread count, sends what its mode says and holds its budget.
#include <gtest/gtest.h>

#include <limits>

#include "ccir_mapping/core/runner/keyframe_feed.h"
#include "ccir_mapping/core/runner/team_link.h"
#include "ccir_mapping/core/runner/team_runner.h"
#include "ccir_mapping/core/simulation/mission.h"

namespace ccir_mapping::core::runner {
namespace {

std::shared_ptr<const routing::WireScan> scanOf(std::size_t bytes, KeyframeId id) {
  auto scan = std::make_shared<routing::WireScan>();
  scan->robot = "robot_a";
  scan->id = id;
  scan->points.assign(bytes, 0);
  return scan;
}

TEST(TeamLink, HoldsItsBudgetSendsControlFirstAndDeliversEachMessageWhole) {
  transport::BridgeParams bridge;
  bridge.budget_bytes_per_s = 50000.0;
  testing::LinkEmulatorParams radio;
  radio.rate_bytes_per_s = 1e9;
  radio.delay_s = 0.05;
  radio.jitter_s = 0.0;
  TeamLink link(bridge, radio, nullptr, 0.0);
  for (KeyframeId id = 0; id < 5; ++id) link.enqueue(scanOf(100000, id), 0.0);
  link.enqueue(routing::Receipt{"robot_b", "robot_a", {1}}, 0.5);  // queued behind 500 KB

  std::vector<std::pair<double, std::size_t>> sent;  // time, wire bytes so far
  std::vector<Delivery> delivered;
  double now = 0.0;
  while (now < 30.0) {
    const double wait = link.delay(now);
    if (std::isinf(wait)) break;
    now += std::max(wait, 1e-6);
    std::optional<Delivery> done;
    if (!link.sendNext(now, &done)) continue;
    sent.emplace_back(now, link.counters().bytes_sent);
    if (done) {
      EXPECT_GE(done->arrival_s, now + radio.delay_s - 1e-9);
      delivered.push_back(std::move(*done));
    }
  }
  ASSERT_EQ(delivered.size(), 6U);
  // The receipt went between two fragments of the first scans, not after 500 KB of them.
  EXPECT_TRUE(std::holds_alternative<routing::Receipt>(delivered.front().message) ||
              std::holds_alternative<routing::Receipt>(delivered[1].message));
  KeyframeId next = 0;
  for (const auto& d : delivered) {
    if (const auto* scan = std::get_if<std::shared_ptr<const routing::WireScan>>(&d.message)) {
      EXPECT_EQ((*scan)->id, next++) << "scans in order";
    }
  }
  // Frames i..k (sent at t_i .. t_k) within burst + rate * (t_k - t_i).
  for (std::size_t i = 0; i < sent.size(); ++i) {
    const std::size_t before = i == 0 ? 0 : sent[i - 1].second;
    for (std::size_t k = i; k < sent.size(); ++k) {
      EXPECT_LE(
          double(sent[k].second - before),
          bridge.burst_bytes + bridge.budget_bytes_per_s * (sent[k].first - sent[i].first) + 1.0);
    }
  }
  EXPECT_EQ(link.counters().messages_sent, 6U);
  EXPECT_GT(link.counters().frames_sent, 6U) << "scans of 100 KB go in fragments";
}

RunnerParams smallMission(routing::RoutingMode mode) {
  RunnerParams p;
  p.mission.robots = 2;
  p.mission.duration_s = 6.0;
  p.mission.start_interval_s = 1.0;
  p.mission.overlap = 1.0;
  p.mission.seed = 5;
  p.mission.world.mine_pillars_x = 2;
  p.mission.world.mine_pillars_y = 2;
  p.mission.world.mine_pillar_size_m = 4.0;
  p.broker.mode = mode;
  p.broker.fixed_rate_every_n = 2;
  p.bridge.budget_bytes_per_s = p.bridge.total_budget_bytes_per_s = 100000.0;
  p.radio.rate_bytes_per_s = 1e9;
  p.backend.max_solve_time_s = 60.0;  // bounded by iterations: the same on any machine
  p.series_period_s = 0.5;
  return p;
}

std::shared_ptr<const place_recognition::PlaceModel> model() {
  static const auto loaded = place_recognition::PlaceModel::load(CCIR_MODEL_DIR);
  return loaded;
}

TEST(TeamRunner, ARunIsTheSameForAnyThreadCountAndHoldsItsBudget) {
  const RunnerParams params = smallMission(routing::RoutingMode::kAll);
  const TeamResult one = TeamRunner(params, model(), 1).run();
  const TeamResult two = TeamRunner(params, model(), 2).run();
  ASSERT_EQ(one.robots.size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    const RobotResult& a = one.robots[i];
    const RobotResult& b = two.robots[i];
    SCOPED_TRACE(a.name);
    EXPECT_GT(a.keyframes, 2U);
    EXPECT_EQ(a.keyframes, b.keyframes);
    EXPECT_EQ(a.broker.features_sent, a.keyframes) << "a word set per keyframe";
    EXPECT_EQ(a.broker.scans_sent, a.keyframes) << "mode all: every keyframe";
    EXPECT_EQ(a.broker.scans_sent, b.broker.scans_sent);
    EXPECT_EQ(a.broker.scans_received, b.broker.scans_received);
    EXPECT_EQ(a.map.known_volume_m3, b.map.known_volume_m3);
    EXPECT_EQ(a.own_loops + a.inter_robot_loops, b.own_loops + b.inter_robot_loops);
    ASSERT_EQ(a.links.size(), 1U);
    const auto& [peer, link] = *a.links.begin();
    EXPECT_EQ(link.bytes_sent, b.links.at(peer).bytes_sent);
    EXPECT_GT(link.bytes_sent, 50000U * a.keyframes) << "scans of ~60 KB";
    // Every window of the series within burst + rate * its length.
    const auto& rows = a.bytes_series.at(peer);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      for (std::size_t m = k + 1; m < rows.size(); ++m) {
        EXPECT_LE(double(rows[m].second - rows[k].second),
                  params.bridge.burst_bytes +
                      params.bridge.budget_bytes_per_s * (rows[m].first - rows[k].first) +
                      transport::wireBytes(params.bridge.fragment_bytes));
      }
    }
  }
  // What one robot sent, the other received (but the last ones, maybe still under way).
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& sender = one.robots[1 - i].broker;
    EXPECT_LE(one.robots[i].broker.scans_received, sender.scans_sent);
    EXPECT_GE(one.robots[i].broker.scans_received + 2, sender.scans_sent);
  }
}

TEST(TeamRunner, FixedRateSendsEveryNthKeyframe) {
  const TeamResult r = TeamRunner(smallMission(routing::RoutingMode::kFixedRate), model()).run();
  for (const auto& robot : r.robots) {
    EXPECT_EQ(robot.broker.scans_sent, (robot.keyframes + 1) / 2) << robot.name;
  }
}

TEST(TeamRunner, RunsEveryKeyframeTheRecordingMakesTheLastOneToo) {
  // Every scan a keyframe, so that the last one, published as the mission ends, is one (a bag
  // replayed into the nodelets holds it).
  RunnerParams params = smallMission(routing::RoutingMode::kFixedRate);
  params.mission.duration_s = 2.0;
  params.preprocessor.keyframe_distance_m = 0.0;
  params.preprocessor.keyframe_rotation_deg = 0.0;
  params.matcher.max_candidates = 1;
  const TeamResult r = TeamRunner(params, model()).run();
  const simulation::Mission mission(params.mission);
  for (int i = 0; i < params.mission.robots; ++i) {
    KeyframeFeed feed(mission, i, params.preprocessor);
    const auto recorded = feed.takeUntil(std::numeric_limits<double>::infinity());
    ASSERT_FALSE(recorded.empty());
    EXPECT_DOUBLE_EQ(recorded.back().published_s, toSeconds(mission.endStamp()));
    EXPECT_EQ(r.robots[i].keyframes, recorded.size()) << r.robots[i].name;
  }
}

TEST(TeamRunner, RadioRangeLinksRobotsOnlyWithinRange) {
  RunnerParams params = smallMission(routing::RoutingMode::kAll);
  params.topology = Topology::kRadioRange;
  params.radio_range_m = 1e4;  // the whole mine
  const TeamResult near = TeamRunner(params, model()).run();
  EXPECT_NEAR(near.link_up_s.at("robot_a->robot_b"), params.mission.duration_s, 1e-6);
  EXPECT_GT(near.robots[0].links.at("robot_b").bytes_sent, 0U);
  params.radio_range_m = 0.0;  // never within range
  const TeamResult apart = TeamRunner(params, model()).run();
  EXPECT_TRUE(apart.link_up_s.empty());
  for (const auto& robot : apart.robots) {
    EXPECT_EQ(robot.broker.scans_received, 0U) << robot.name;
    for (const auto& [peer, link] : robot.links) EXPECT_EQ(link.bytes_sent, 0U) << peer;
  }
}

TEST(TeamRunner, RefusesInvalidParametersNamingThem) {
  RunnerParams p;
  p.step_s = 0.0;
  try {
    TeamRunner(p, model());
    FAIL() << "accepted step_s 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("step_s"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ccir_mapping::core::runner
