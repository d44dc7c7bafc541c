// link_proxy: relays TCP connections on 127.0.0.1 through an emulated radio link (rate, delay,
// jitter, loss, outages; seeded) and can cut them at given times, for tests of the bridge
// between ROS masters (netem is not available here). On SIGINT/SIGTERM it writes what entered
// it each way as CSV (direction,time_s,bytes; direction "up" = towards the target).
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/testing/link_proxy.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
using ccir_mapping::core::testing::LinkProxy;
using ccir_mapping::core::testing::LinkProxyParams;

namespace {

struct Options {
  LinkProxyParams params;
  std::vector<double> cut_at_s;
  std::vector<double> outage_s;  // start, end pairs
  std::string log_path;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  LinkProxyParams& params = o->params;
  po::options_description options("link_proxy: an emulated radio link between two TCP ends");
  options.add_options()("help", "this help")("listen-port",
                                             po::value<int>(&params.listen_port)->default_value(0),
                                             "port to accept on (127.0.0.1; 0 = any, printed)")(
      "target-port", po::value<int>(&params.target_port)->required(), "port to relay to")(
      "target-host", po::value<std::string>(&params.target_host)->default_value("127.0.0.1"),
      "address to relay to")("rate-bytes-per-s",
                             po::value<double>(&params.link.rate_bytes_per_s)->default_value(1e6),
                             "link rate each way")(
      "delay-s", po::value<double>(&params.link.delay_s)->default_value(0.01), "one-way delay")(
      "jitter-s", po::value<double>(&params.link.jitter_s)->default_value(0.002), "delay jitter")(
      "loss", po::value<double>(&params.link.loss)->default_value(0.0),
      "share of chunks lost once (delivered a retransmission later)")(
      "seed", po::value<std::uint64_t>(&params.link.seed)->default_value(1), "random seed")(
      "cut-at-s", po::value<std::vector<double>>(&o->cut_at_s)->multitoken(),
      "seconds after start at which every connection is closed")(
      "outage-s", po::value<std::vector<double>>(&o->outage_s)->multitoken(),
      "START END [START END ...]: seconds after start between which nothing arrives either "
      "way (connections stay open; what was sent arrives after)")(
      "log", po::value<std::string>(&o->log_path), "CSV of the bytes relayed, written at exit");
  if (const auto exit_code = tools::parseCommandLine("link_proxy", options, argc, argv)) {
    return exit_code;
  }
  if (o->outage_s.size() % 2) {
    std::cerr << "link_proxy: --outage-s takes pairs START END\n";
    return 2;
  }
  for (std::size_t i = 0; i < o->outage_s.size(); i += 2) {
    params.link.outages.emplace_back(o->outage_s[i], o->outage_s[i + 1]);
  }
  return std::nullopt;
}

/// Relays until SIGINT or SIGTERM, cutting every connection at the times asked; throws
/// std::exception when the proxy cannot listen.
std::unique_ptr<LinkProxy> run(Options o) {
  // Signals are taken by sigwait below, not by a handler (blocked before any thread starts).
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  auto proxy = std::make_unique<LinkProxy>(o.params);
  std::cout << "link_proxy: 127.0.0.1:" << proxy->port() << " -> " << o.params.target_host << ":"
            << o.params.target_port << std::endl;
  std::thread cutter([cut_at_s = std::move(o.cut_at_s), &proxy = *proxy]() mutable {
    const auto start = std::chrono::steady_clock::now();
    std::sort(cut_at_s.begin(), cut_at_s.end());
    for (const double t : cut_at_s) {
      std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                std::chrono::duration<double>(t)));
      proxy.cut();
      std::cout << "link_proxy: cut every connection at " << t << " s" << std::endl;
    }
  });
  cutter.detach();
  int signal = 0;
  sigwait(&stop, &signal);
  return proxy;
}

/// The CSV of what the proxy relayed each way; false when it cannot be written.
bool report(const Options& o, const LinkProxy& proxy) {
  if (o.log_path.empty()) return true;
  std::ofstream log(o.log_path);
  log << "direction,time_s,bytes\n";
  for (const bool up : {true, false}) {
    for (const auto& [t, bytes] : proxy.forwarded(up)) {
      log << (up ? "up" : "down") << "," << t << "," << bytes << "\n";
    }
  }
  if (log) return true;
  std::cerr << "link_proxy: cannot write " << o.log_path << "\n";
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  std::unique_ptr<LinkProxy> proxy;
  try {
    proxy = run(options);
  } catch (const std::exception& e) {
    std::cerr << "link_proxy: " << e.what() << "\n";
    return 1;
  }
  const bool written = report(options, *proxy);
  std::_Exit(written ? 0 : 1);  // the cutter may still sleep
}
