// bench_bridge: two bridges over loopback TCP through an emulated radio link (link_proxy's
// LinkProxy, faster than the budget so the bridge is what limits), scans offered at 1.6 times
// the budget and small control messages at 20 Hz. Prints JSON: the share of the budget used on
// the wire while saturated, control-message latency (p50/p99) with priorities and, as the
// baseline measured in the same run, with control messages queued behind scans (one class),
// and the process's CPU time per MB forwarded (both bridges and the proxy).
#include <time.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/testing/link_proxy.h"
#include "ccir_mapping/core/transport/bridge_stage.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
using namespace ccir_mapping::core::transport;
using ccir_mapping::core::testing::freeLoopbackPort;
using ccir_mapping::core::testing::LinkProxy;
using ccir_mapping::core::testing::LinkProxyParams;
using Clock = std::chrono::steady_clock;

namespace {

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Options {
  double duration_s = 15.0;
  double budget = 150000.0;
  std::size_t scan_bytes = 120000;
  double scan_hz = 2.0;
  double control_hz = 20.0;
  bool compress = false;
};

struct Result {
  double utilisation = 0.0;
  double p50_ms = 0.0;
  double p99_ms = 0.0;
  double cpu_s_per_mb = 0.0;
  std::size_t control_delivered = 0;
  std::size_t control_sent = 0;
};

TopicInfo topic(const std::string& name, Priority priority, bool compress) {
  TopicInfo t;
  t.name = name;
  t.type = "bench/Bytes";
  t.md5 = "0123456789abcdef0123456789abcdef";
  t.definition = "uint8[] data\n";
  t.policy.priority = priority;
  t.policy.max_queued = 10000;
  t.compressed = compress;
  return t;
}

Result run(const Options& o, bool control_first) {
  BridgeParams p;
  p.team_key = "bench team key, long enough";
  p.budget_bytes_per_s = o.budget;
  p.total_budget_bytes_per_s = o.budget;
  const int port_a = freeLoopbackPort();
  const int port_b = freeLoopbackPort();
  LinkProxyParams link;
  link.target_port = port_b;
  link.link.rate_bytes_per_s = 10.0 * o.budget;
  LinkProxy proxy(link);

  std::mutex mutex;
  std::condition_variable changed;
  std::map<std::uint32_t, Clock::time_point> control_arrived;
  std::size_t bytes_delivered = 0;
  const auto number = [](const std::vector<std::uint8_t>& b) {
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | b[3] << 24);
  };
  BridgeParams pa = p;
  pa.listen_port = port_a;
  pa.peers = {{"robot_b", "127.0.0.1", proxy.port()}};
  BridgeParams pb = p;
  pb.listen_port = port_b;
  pb.peers = {{"robot_a", "127.0.0.1", port_a}};
  BridgeStage a(
      pa, "robot_a", [](auto&&...) {}, [](auto&&...) {});
  BridgeStage b(
      pb, "robot_b",
      [&](const std::string&, InboxMessage m) {
        std::lock_guard<std::mutex> lock(mutex);
        bytes_delivered += m.bytes.size();
        if (m.topic.name == "inbox/control") control_arrived[number(m.bytes)] = Clock::now();
        changed.notify_all();
      },
      [](auto&&...) {});
  b.start();
  a.start();

  const TopicInfo scans = topic("inbox/scans", Priority::kBulk, o.compress);
  const TopicInfo control =
      topic("inbox/control", control_first ? Priority::kControl : Priority::kBulk, false);
  std::mt19937 rng(7);
  std::vector<std::uint8_t> scan(o.scan_bytes);
  for (auto& byte : scan) byte = static_cast<std::uint8_t>(rng());
  std::map<std::uint32_t, Clock::time_point> control_sent;
  const double cpu0 = cpuSeconds();
  const auto start = Clock::now();
  const int ticks = static_cast<int>(o.duration_s * o.control_hz);
  const int scan_every = std::max(1, static_cast<int>(o.control_hz / o.scan_hz));
  for (int k = 0; k < ticks; ++k) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(k / o.control_hz)));
    std::vector<std::uint8_t> c(200, 0);
    for (int i = 0; i < 4; ++i) c[i] = static_cast<std::uint8_t>(k >> (8 * i));
    control_sent[k] = Clock::now();
    a.publish(control, std::move(c));
    if (k % scan_every == 0) a.publish(scans, scan);
  }
  std::size_t delivered_bytes = 0;
  {
    std::unique_lock<std::mutex> lock(mutex);
    changed.wait_for(lock, std::chrono::seconds(2),
                     [&] { return control_arrived.size() == control_sent.size(); });
    delivered_bytes = bytes_delivered;
  }
  const double cpu_s = cpuSeconds() - cpu0;

  Result r;
  // Utilisation over the saturated part: after the first burst has gone, to the end of offers.
  const auto wire = proxy.forwarded(true);
  const double t0 = wire.empty() ? 0.0 : wire.front().first + 3.0;
  const double t1 = wire.empty() ? 0.0 : wire.front().first + o.duration_s;
  std::size_t in_window = 0;
  for (const auto& [t, n] : wire) {
    if (t >= t0 && t < t1) in_window += n;
  }
  r.utilisation = static_cast<double>(in_window) / ((t1 - t0) * o.budget);
  std::vector<double> latency;
  for (const auto& [k, sent] : control_sent) {
    const auto it = control_arrived.find(k);
    if (it != control_arrived.end()) {
      latency.push_back(1000.0 * std::chrono::duration<double>(it->second - sent).count());
    }
  }
  std::sort(latency.begin(), latency.end());
  if (!latency.empty()) {
    r.p50_ms = latency[latency.size() / 2];
    r.p99_ms = latency[static_cast<std::size_t>(0.99 * static_cast<double>(latency.size() - 1))];
  }
  r.control_sent = control_sent.size();
  r.control_delivered = latency.size();
  r.cpu_s_per_mb = cpu_s / std::max(1e-9, static_cast<double>(delivered_bytes) / 1e6);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  po::options_description options("bench_bridge: the bridge saturated by scans");
  options.add_options()("help", "this help")(
      "duration-s", po::value<double>(&o.duration_s)->default_value(o.duration_s),
      "seconds of offered traffic per run")(
      "budget-bytes-per-s", po::value<double>(&o.budget)->default_value(o.budget), "link budget")(
      "scan-bytes", po::value<std::size_t>(&o.scan_bytes)->default_value(o.scan_bytes),
      "bytes per scan (random: incompressible)")(
      "scan-hz", po::value<double>(&o.scan_hz)->default_value(o.scan_hz), "scans per second")(
      "compress", po::bool_switch(&o.compress), "zstd the scans");
  if (const auto exit_code = tools::parseCommandLine("bench_bridge", options, argc, argv)) {
    return *exit_code;
  }
  if (o.duration_s < 5.0) {
    return tools::usageError("bench_bridge",
                             "--duration-s must be at least 5 (3 s of burst are skipped)");
  }
  const Result with = run(o, true);
  const Result baseline = run(o, false);
  std::printf(
      "{\"budget_bytes_per_s\": %.0f, \"offered_bytes_per_s\": %.0f, \"duration_s\": %.1f,\n"
      " \"utilisation\": %.3f, \"utilisation_target\": 0.9,\n"
      " \"control_latency_ms\": {\"p50\": %.1f, \"p99\": %.1f, \"delivered\": %zu, \"sent\": "
      "%zu},\n"
      " \"baseline_one_class_latency_ms\": {\"p50\": %.1f, \"p99\": %.1f},\n"
      " \"latency_ratio_p99\": %.3f,\n"
      " \"cpu_s_per_mb\": %.4f, \"compress\": %s}\n",
      o.budget, static_cast<double>(o.scan_bytes) * o.scan_hz + 200 * o.control_hz, o.duration_s,
      with.utilisation, with.p50_ms, with.p99_ms, with.control_delivered, with.control_sent,
      baseline.p50_ms, baseline.p99_ms, with.p99_ms / std::max(1e-9, baseline.p99_ms),
      with.cpu_s_per_mb, o.compress ? "true" : "false");
  return 0;
}
