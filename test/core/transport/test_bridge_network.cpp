// The bridge's network side over loopback TCP, without ROS: two Bridges through a LinkProxy that
// records what the sender put on the wire and cuts the connection once. Reliable messages arrive
// exactly once and in order across the cut, the sender stays within its budget in every 1 s
// window while scans saturate it, control messages overtake the scans, and a stranger's
// connection, a replayed HELLO and a flood of connections are refused and counted without
// disturbing the link; a teammate sending at line rate is read no faster than twice the budget;
// on a mission clock, the budget holds per mission second.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>

#include <boost/asio.hpp>

#include "ccir_mapping/core/testing/link_proxy.h"
#include "ccir_mapping/core/transport/bridge_stage.h"
#include "numbered_bytes.h"

namespace ccir_mapping::core::transport {
namespace {

using testing::freeLoopbackPort;
using testing::LinkProxy;
using testing::LinkProxyParams;

using Clock = std::chrono::steady_clock;
const std::string kKey = "a team key of some length";

/// What one bridge received, awaitable.
struct Inbox {
  std::mutex mutex;
  std::condition_variable changed;
  std::map<std::string, std::vector<std::vector<std::uint8_t>>> by_topic;
  std::map<std::string, std::vector<Clock::time_point>> arrived;

  void add(const std::string& peer, InboxMessage m) {
    std::lock_guard<std::mutex> lock(mutex);
    by_topic[peer + ":" + m.topic.name].push_back(std::move(m.bytes));
    arrived[peer + ":" + m.topic.name].push_back(Clock::now());
    changed.notify_all();
  }
  bool waitFor(const std::string& key, std::size_t n, double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex);
    return changed.wait_for(lock, std::chrono::duration<double>(timeout_s),
                            [&] { return by_topic[key].size() >= n; });
  }
};

BridgeParams params(int listen_port, const std::string& peer, int peer_port) {
  BridgeParams p;
  p.listen_port = listen_port;
  p.team_key = kKey;
  p.peers = {{peer, "127.0.0.1", peer_port}};
  p.budget_bytes_per_s = 100000.0;
  p.total_budget_bytes_per_s = 100000.0;
  p.burst_bytes = 32768;
  p.fragment_bytes = 16384;
  p.reconnect_min_s = 0.1;
  p.reconnect_max_s = 0.5;
  return p;
}

TopicInfo topic(const std::string& name, Priority priority) {
  TopicInfo t;
  t.name = name;
  t.type = "test/Bytes";
  t.md5 = "0123456789abcdef0123456789abcdef";
  t.definition = "uint8[] data\n";
  t.policy.priority = priority;
  t.policy.max_queued = 1000;
  return t;
}

using test::number;
using test::numbered;

TEST(BridgeNetwork, ExactlyOnceWithinBudgetAcrossACutConnection) {
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  LinkProxyParams link;
  link.target_port = port_b;
  link.link.rate_bytes_per_s = 1e6;  // faster than the budget: the bridge is what limits
  link.link.delay_s = 0.01;
  link.link.jitter_s = 0.002;
  LinkProxy proxy(link);

  Inbox at_b;
  std::vector<std::string> warnings_b;
  std::mutex warnings_mutex;
  // robot_a sorts first: it dials robot_b, through the proxy.
  BridgeStage a(
      params(port_a, "robot_b", proxy.port()), "robot_a", [](auto&&...) {}, [](auto&&...) {});
  BridgeStage b(
      params(port_b, "robot_a", port_a), "robot_b",
      [&](const std::string& peer, InboxMessage m) { at_b.add(peer, std::move(m)); },
      [&](bool warning, const std::string& text) {
        std::lock_guard<std::mutex> lock(warnings_mutex);
        if (warning) warnings_b.push_back(text);
      });
  a.start();
  b.start();

  // 6 s: a 15 KB scan every 0.1 s (1.5 times the budget) and an offer every 0.05 s; the
  // connection is cut at 2.5 s.
  const TopicInfo scans = topic("inbox/scans", Priority::kBulk);
  const TopicInfo offers = topic("inbox/offers", Priority::kControl);
  std::map<std::uint32_t, Clock::time_point> offered;
  const auto start = Clock::now();
  for (std::uint32_t tick = 0; tick < 120; ++tick) {
    std::this_thread::sleep_until(start + std::chrono::milliseconds(50 * tick));  // pacing
    if (tick == 50) proxy.cut();
    offered[tick] = Clock::now();
    a.publish(offers, numbered(100, tick));
    if (tick % 2 == 0) a.publish(scans, numbered(15000, tick / 2));
  }
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/offers", 120, 20.0));
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/scans", 60, 30.0))
      << at_b.by_topic["robot_a:inbox/scans"].size() << " scans";

  // Exactly once, in order, across the cut.
  for (const std::string key : {"robot_a:inbox/offers", "robot_a:inbox/scans"}) {
    const auto& got = at_b.by_topic[key];
    for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(number(got[i]), i) << key;
  }
  EXPECT_EQ(at_b.by_topic["robot_a:inbox/offers"].size(), 120U);
  EXPECT_EQ(at_b.by_topic["robot_a:inbox/scans"].size(), 60U);
  EXPECT_GE(proxy.connections(), 2U) << "a reconnected after the cut";
  {
    std::lock_guard<std::mutex> lock(warnings_mutex);
    EXPECT_FALSE(warnings_b.empty()) << "b noticed the cut";
  }

  // Within budget in every window of 1 s (and of 5 s) of what reached the wire.
  const auto wire = proxy.forwarded();
  ASSERT_FALSE(wire.empty());
  for (const double window : {1.0, 5.0}) {
    for (std::size_t i = 0; i < wire.size(); ++i) {
      std::size_t bytes = 0;
      for (std::size_t j = i; j < wire.size() && wire[j].first < wire[i].first + window; ++j)
        bytes += wire[j].second;
      ASSERT_LE(bytes, 32768 + 100000 * window) << window << " s from " << wire[i].first;
    }
  }
  std::size_t total = 0;
  for (const auto& [t, n] : wire) total += n;
  const double seconds = wire.back().first - wire.front().first;
  EXPECT_GT(total / seconds, 0.7 * 100000) << "the saturated link was used";

  // Offers kept ahead of the scans: most arrived within 0.3 s (a 16 KB fragment takes 0.16 s).
  std::vector<double> latency;
  const auto& offer_times = at_b.arrived["robot_a:inbox/offers"];
  for (std::size_t i = 0; i < offer_times.size(); ++i) {
    latency.push_back(std::chrono::duration<double>(offer_times[i] - offered[i]).count());
  }
  std::sort(latency.begin(), latency.end());
  EXPECT_LT(latency[latency.size() / 2], 0.3);
  RecordProperty("offer_latency_p50_ms", static_cast<int>(1000 * latency[latency.size() / 2]));
  RecordProperty("offer_latency_max_ms", static_cast<int>(1000 * latency.back()));
  RecordProperty("wire_rate_bytes_per_s", static_cast<int>(total / seconds));

  const auto reports = a.reports();
  ASSERT_EQ(reports.size(), 1U);
  EXPECT_TRUE(reports[0].connected);
  EXPECT_EQ(reports[0].peer, "robot_b");
  EXPECT_GT(reports[0].sent.bytes_sent, 900000U);
  EXPECT_EQ(b.reports()[0].drops.at("missing"), 0U) << "no reliable message was given up";
}

TEST(BridgeNetwork, AStrangerIsRefusedAndCountedAndTheTeamLinkCarriesOn) {
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  Inbox at_b;
  std::mutex log_mutex;
  std::vector<std::string> b_log;
  BridgeStage a(
      params(port_a, "robot_b", port_b), "robot_a", [](auto&&...) {}, [](auto&&...) {});
  BridgeStage b(
      params(port_b, "robot_a", port_a), "robot_b",
      [&](const std::string& peer, InboxMessage m) { at_b.add(peer, std::move(m)); },
      [&](bool, const std::string& text) {
        std::lock_guard<std::mutex> lock(log_mutex);
        b_log.push_back(text);
      });
  b.start();

  // A stranger: garbage, then a well-formed HELLO under another key.
  boost::asio::io_context io;
  for (const auto& bytes :
       {std::vector<std::uint8_t>(200, 0x5a),
        encodeFrame({FrameType::kHello, 0, 0, 1, 0, 1, encodeHello({"robot_a", 7})},
                    "wrong key")}) {
    boost::asio::ip::tcp::socket stranger(io);
    stranger.connect(
        {boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_b)});
    boost::asio::write(stranger, boost::asio::buffer(bytes));
    std::array<std::uint8_t, 16> reply;
    boost::system::error_code ec;
    stranger.read_some(boost::asio::buffer(reply), ec);  // returns when b closes it
    EXPECT_TRUE(ec) << "b closed the stranger's connection";
  }
  // A HELLO with the key, then half a frame, then gone: identified, and counted as truncated.
  {
    auto bytes = encodeFrame({FrameType::kHello, 0, 0, 1, 0, 1, encodeHello({"robot_a", 7})}, kKey);
    const auto next =
        encodeFrame({FrameType::kAck, 0, 0, 1, 0, 1, std::vector<std::uint8_t>(10)}, kKey);
    bytes.insert(bytes.end(), next.begin(), next.begin() + 20);
    boost::asio::ip::tcp::socket half(io);
    half.connect({boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_b)});
    boost::asio::write(half, boost::asio::buffer(bytes));
    // b answers the HELLO with its own: read it, so the close comes after b has our bytes.
    std::array<std::uint8_t, 16> reply;
    boost::asio::read(half, boost::asio::buffer(reply));
  }
  std::vector<LinkReport> reports;
  for (int i = 0; i < 100; ++i) {  // b sees the close on its own thread
    reports = b.reports();
    if (reports[0].drops.count("truncated")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(reports[0].drops["truncated"], 1U);
  ASSERT_EQ(reports.size(), 2U);
  EXPECT_EQ(reports[1].peer, "");
  EXPECT_EQ(reports[1].drops.at("refused: bad magic"), 1U);
  EXPECT_EQ(reports[1].drops.at("refused: bad mac"), 1U);

  a.start();
  EXPECT_TRUE(a.publish(topic("inbox/offers", Priority::kControl), numbered(100, 0)));
  TopicInfo retyped = topic("inbox/offers", Priority::kControl);
  retyped.md5 = "fedcba9876543210fedcba9876543210";
  EXPECT_FALSE(a.publish(retyped, numbered(100, 1))) << "a topic keeps the type it started with";
  EXPECT_EQ(a.reports()[0].drops.at("type_changed"), 1U);
  EXPECT_TRUE(at_b.waitFor("robot_a:inbox/offers", 1, 10.0));

  // A HELLO replayed while the link is up and heard from (an attacker's recording of a's) is
  // refused: the link stays up and carries on.
  {
    boost::asio::ip::tcp::socket replay(io);
    replay.connect(
        {boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_b)});
    boost::asio::write(replay,
                       boost::asio::buffer(encodeFrame(
                           {FrameType::kHello, 0, 0, 1, 0, 1, encodeHello({"robot_a", 7})}, kKey)));
    std::array<std::uint8_t, 16> reply;
    boost::system::error_code ec;
    replay.read_some(boost::asio::buffer(reply), ec);
    EXPECT_EQ(ec, boost::asio::error::eof) << "b closed the replay without a word";
  }
  EXPECT_TRUE(a.publish(topic("inbox/offers", Priority::kControl), numbered(100, 2)));
  EXPECT_TRUE(at_b.waitFor("robot_a:inbox/offers", 2, 10.0));
  reports = b.reports();
  EXPECT_TRUE(reports[0].connected);
  EXPECT_EQ(reports.back().drops.at("refused: link already up"), 1U);
  std::lock_guard<std::mutex> lock(log_mutex);
  EXPECT_EQ(std::count_if(b_log.begin(), b_log.end(),
                          [](const std::string& t) {
                            return t.find("closed") != std::string::npos &&
                                   t.find("link to robot_a") == 0;
                          }),
            1)
      << "only the half-frame connection's close";
}

// Replaying at half speed, the budget holds per mission second: 300 KB take at least as many
// mission seconds as the budget allows (twice as many wall seconds), and the mission clock's
// jump when the replay starts neither closes the link as silent nor lets a burst through.
TEST(BridgeNetwork, FollowsTheMissionClockAtHalfSpeed) {
  const auto wall_start = Clock::now();
  const auto mission_s = [wall_start] {
    const double wall = std::chrono::duration<double>(Clock::now() - wall_start).count();
    return (wall < 0.5 ? 0.0 : 1000.0) + 0.5 * wall;  // the replay starts 1000 s in
  };
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  Inbox at_b;
  std::vector<std::string> warnings;
  std::mutex warnings_mutex;
  const auto log = [&](bool warning, const std::string& text) {
    std::lock_guard<std::mutex> lock(warnings_mutex);
    if (warning) warnings.push_back(text);
  };
  BridgeParams pa = params(port_a, "robot_b", port_b);
  pa.peer_timeout_s = 2.0;  // far less than the jump
  BridgeParams pb = params(port_b, "robot_a", port_a);
  pb.peer_timeout_s = 2.0;
  BridgeStage a(
      pa, "robot_a", [](auto&&...) {}, log, mission_s);
  BridgeStage b(
      pb, "robot_b", [&](const std::string& peer, InboxMessage m) { at_b.add(peer, std::move(m)); },
      log, mission_s);
  a.start();
  b.start();
  const TopicInfo scans = topic("inbox/scans", Priority::kBulk);
  ASSERT_TRUE(a.publish(scans, numbered(1000, 0)));
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/scans", 1, 20.0)) << "the link came up";
  std::this_thread::sleep_until(wall_start + std::chrono::milliseconds(700));  // past the jump
  const double sent_at_s = mission_s();
  const double reported_at_s = a.reports()[0].at_s;
  constexpr int kScans = 20;
  for (std::uint32_t n = 1; n <= kScans; ++n) a.publish(scans, numbered(15000, n));
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/scans", kScans + 1, 60.0));
  const double took_s = mission_s() - sent_at_s;
  const double budget = pa.budget_bytes_per_s;
  // Payload only (the wire carries more): at least (bytes - burst) / rate mission seconds.
  EXPECT_GE(took_s, (kScans * 15000.0 - pa.burst_bytes) / budget) << "mission seconds";
  // Reports are stamped on the same clock (LinkStats rates are per its second).
  EXPECT_NEAR(a.reports()[0].at_s - reported_at_s, took_s, 0.5);
  std::lock_guard<std::mutex> lock(warnings_mutex);
  for (const auto& w : warnings) ADD_FAILURE() << w;
}

// A flood of 200 connections that say nothing: 16 wait to be identified, the rest are refused
// at once, and the team's link carries on meanwhile.
TEST(BridgeNetwork, AConnectionFloodIsRefusedAndTheTeamLinkCarriesOn) {
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  Inbox at_b;
  BridgeStage a(
      params(port_a, "robot_b", port_b), "robot_a", [](auto&&...) {}, [](auto&&...) {});
  BridgeStage b(
      params(port_b, "robot_a", port_a), "robot_b",
      [&](const std::string& peer, InboxMessage m) { at_b.add(peer, std::move(m)); },
      [](auto&&...) {});
  b.start();
  a.start();
  const TopicInfo offers = topic("inbox/offers", Priority::kControl);
  ASSERT_TRUE(a.publish(offers, numbered(100, 0)));
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/offers", 1, 20.0)) << "the link came up";

  boost::asio::io_context io;
  std::vector<boost::asio::ip::tcp::socket> flood;
  for (int i = 0; i < 200; ++i) {
    flood.emplace_back(io).connect(
        {boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_b)});
  }
  for (std::uint32_t n = 1; n <= 20; ++n) a.publish(offers, numbered(100, n));
  EXPECT_TRUE(at_b.waitFor("robot_a:inbox/offers", 21, 20.0)) << "the link carried on";
  std::vector<LinkReport> reports;
  for (int i = 0; i < 500; ++i) {  // b accepts on its own thread
    reports = b.reports();
    if (reports.size() == 2 &&
        reports[1].drops["refused: too_many_unidentified"] + reports[1].drops["refused: silent"] >=
            184) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(reports.size(), 2U);
  // (On a machine slow enough, some of the 16 waiting time out as silent before the flood ends,
  // and as many more wait in their place.)
  EXPECT_LE(reports[1].drops["refused: too_many_unidentified"], 184U);
  EXPECT_GE(
      reports[1].drops["refused: too_many_unidentified"] + reports[1].drops["refused: silent"],
      184U);
  EXPECT_TRUE(reports[0].connected);
}

// A teammate that sends at line rate (its budget set a thousand times higher) and a stranger
// writing garbage as fast as it can connect: the victim reads the teammate no faster than twice
// its own budget (TCP holds the rest back), refuses the stranger, and its honest link carries
// its traffic both ways meanwhile.
TEST(BridgeNetwork, APeerSendingAtLineRateIsHeldBackAndTheHonestLinkCarriesOn) {
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  const int port_c = freeLoopbackPort();
  Inbox at_a, at_b;
  BridgeParams pb = params(port_b, "robot_a", port_a);
  pb.peers.push_back({"robot_c", "127.0.0.1", port_c});
  BridgeParams pc = params(port_c, "robot_b", port_b);
  pc.budget_bytes_per_s = pc.total_budget_bytes_per_s = 1e8;
  BridgeStage a(
      params(port_a, "robot_b", port_b), "robot_a",
      [&](const std::string& peer, InboxMessage m) { at_a.add(peer, std::move(m)); },
      [](auto&&...) {});
  BridgeStage b(
      pb, "robot_b", [&](const std::string& peer, InboxMessage m) { at_b.add(peer, std::move(m)); },
      [](auto&&...) {});
  BridgeStage c(
      pc, "robot_c", [](auto&&...) {}, [](auto&&...) {});
  a.start();
  b.start();
  c.start();
  const TopicInfo offers = topic("inbox/offers", Priority::kControl);
  const TopicInfo scans = topic("inbox/scans", Priority::kBulk);
  ASSERT_TRUE(a.publish(offers, numbered(100, 0)));
  ASSERT_TRUE(c.publish(scans, numbered(15000, 0)));
  ASSERT_TRUE(at_b.waitFor("robot_a:inbox/offers", 1, 20.0)) << "a's link came up";
  ASSERT_TRUE(at_b.waitFor("robot_c:inbox/scans", 1, 20.0)) << "c's link came up";
  const auto received_from_c = [&b] {
    for (const auto& report : b.reports()) {
      if (report.peer == "robot_c") return report.received.bytes_received;
    }
    return std::uint64_t{0};
  };

  std::atomic<bool> stop{false};
  const auto start = Clock::now();
  const std::uint64_t c_before = received_from_c();
  std::thread line_rate([&] {
    for (std::uint32_t n = 1; !stop; ++n) {
      c.publish(scans, numbered(15000, n));
      if (n % 100 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));  // 150 MB/s
    }
  });
  std::atomic<int> stranger_connections{0};
  std::thread stranger([&] {
    boost::asio::io_context io;
    const std::vector<std::uint8_t> garbage(65536, 0xa5);
    while (!stop) {
      boost::asio::ip::tcp::socket socket(io);
      boost::system::error_code ec;
      socket.connect(
          {boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port_b)}, ec);
      if (!ec) boost::asio::write(socket, boost::asio::buffer(garbage), ec);
      ++stranger_connections;
    }
  });

  // The honest traffic: a's 30 scans of 10 KB (3 s of its budget) and 30 offers, b's 30 offers.
  for (std::uint32_t n = 1; n <= 30; ++n) {
    a.publish(scans, numbered(10000, n));
    a.publish(offers, numbered(100, n));
    b.publish(offers, numbered(100, n), "robot_a");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const bool offers_reached_b = at_b.waitFor("robot_a:inbox/offers", 31, 60.0);
  const bool offers_reached_a = at_a.waitFor("robot_b:inbox/offers", 30, 60.0);
  const bool scans_reached_b = at_b.waitFor("robot_a:inbox/scans", 30, 60.0);
  // Counted before the time is taken: the window the bytes came in lies inside took_s.
  const std::uint64_t from_c = received_from_c() - c_before;
  const double took_s = std::chrono::duration<double>(Clock::now() - start).count();
  stop = true;
  line_rate.join();
  stranger.join();

  EXPECT_TRUE(offers_reached_b && offers_reached_a && scans_reached_b)
      << "the honest link carried its traffic both ways";
  // The documented bound (docs/bridge.md): twice the budget, in bursts of twice burst_bytes and
  // 64 KB.
  const double read_burst = 2.0 * pb.burst_bytes + 65536;
  EXPECT_LE(from_c, read_burst + 2.0 * pb.budget_bytes_per_s * took_s)
      << "b read c no faster than twice its budget over " << took_s << " s";
  EXPECT_GT(c.reports()[0].sent.dropped_queue_full, 0U) << "c had more to send than it could";
  EXPECT_GT(stranger_connections, 0);
  EXPECT_GE(b.reports().back().drops["refused: bad magic"], 1U);
  RecordProperty("honest_traffic_ms", static_cast<int>(1000 * took_s));
  RecordProperty("read_from_line_rate_peer_bytes_per_s", static_cast<int>(from_c / took_s));
}

TEST(BridgeNetwork, APortInUseIsAnErrorNamingTheParameter) {
  boost::asio::io_context io;
  boost::asio::ip::tcp::acceptor taken(io, {boost::asio::ip::tcp::v4(), 0});
  BridgeStage bridge(
      params(taken.local_endpoint().port(), "robot_b", 1), "robot_a", [](auto&&...) {},
      [](auto&&...) {});
  try {
    bridge.start();
    FAIL() << "started on a port in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("listen_port"), std::string::npos) << e.what();
  }
  EXPECT_THROW(BridgeStage(BridgeParams{params(0, "robot_a", 1)}, "robot_a", nullptr, nullptr),
               std::invalid_argument)
      << "a peer named like this robot";
  BridgeParams anywhere = params(0, "robot_b", 1);
  anywhere.listen_address = "radio0";
  ASSERT_EQ(anywhere.validate("robot_a").size(), 1U);
  EXPECT_NE(anywhere.validate("robot_a")[0].find("listen_address 'radio0'"), std::string::npos);
  EXPECT_TRUE(BridgeParams{}.validate("robot_a").empty()) << "the defaults are valid";
}

}  // namespace
}  // namespace ccir_mapping::core::transport
