// simulate_team: writes a simulated team mission — one rosbag and one ground-truth file per robot
// and mission.yaml — from a world, a team and a seed. Every simulation parameter has a flag;
// --help lists them with unit, range and default. Exit codes: 0 done, 1 cannot write, 2 bad
// arguments.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <thread>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/common/field_check.h"
#include "ccir_mapping/core/simulation/mission.h"
#include "ccir_mapping/ros/mission_files.h"
#include "command_line.h"
#include "flag_registrar.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
namespace sim = ccir_mapping::core::simulation;
namespace io = ccir_mapping::simulation_io;
using tools::flagName;
using tools::FlagRegistrar;
using tools::text;

namespace {

constexpr int kExitBadArguments = 2;

/// Writes the robots' recordings on `threads` threads; each robot's data depend only on the
/// mission, so the result does not depend on the thread count.
std::vector<io::RobotRecording> recordAll(const sim::Mission& mission, const std::string& dir,
                                          const io::BagOptions& options, int threads) {
  const int robots = static_cast<int>(mission.robots().size());
  std::vector<io::RobotRecording> recordings(robots);
  std::vector<std::string> errors(robots);
  std::atomic<int> next{0};
  auto work = [&] {
    for (int i = next++; i < robots; i = next++) {
      try {
        recordings[i] = io::writeRobotRecording(mission, i, dir, options);
      } catch (const std::exception& e) {
        errors[i] = e.what();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::min(threads, robots); ++t) pool.emplace_back(work);
  for (auto& thread : pool) thread.join();
  for (const auto& error : errors) {
    if (!error.empty()) throw std::runtime_error(error);
  }
  return recordings;
}

struct Options {
  sim::MissionParams params;
  std::string out_dir = "mission";
  io::BagOptions bag_options;
  int threads = 0;
  std::string command_line = "simulate_team";
};

/// The options, or the exit code to end with (help, bad arguments).
std::optional<int> parse(int argc, char** argv, Options* o) {
  std::string compression = "none";
  po::options_description options(
      "Usage: simulate_team [--world mine] [--robots 3] [--duration 120] [--seed 7] --out DIR\n\n"
      "Simulates a team of robots with VLP-16 lidars and drifting odometry in a mine, building,\n"
      "cave or cluttered room, and writes DIR/<robot>.bag (velodyne_points, odom, tf,\n"
      "ground_truth, sim/world), DIR/<robot>_gt.txt (stamp x y z qx qy qz qw) and\n"
      "DIR/mission.yaml (parameters and each robot's true start pose in the world).\n"
      "A flag may be shortened while it stays unambiguous (--duration for --duration-s).\n\n"
      "Options",
      110);
  options.add_options()("help,h", "print this help and exit")(
      "out", po::value<std::string>(&o->out_dir)->default_value(o->out_dir)->value_name("dir"),
      "output directory (created if missing)")(
      "compression", po::value<std::string>(&compression)->default_value(compression),
      "bag compression; allowed none | lz4 | bz2")(
      "namespace-topics", po::bool_switch(&o->bag_options.namespace_topics),
      "record topics under /<robot>/ (to replay several robots into one master)")(
      "threads", po::value<int>(&o->threads)->default_value(0),
      "robots written in parallel; 0: one per core");
  FlagRegistrar registrar(&options);
  sim::MissionParams::fields(o->params, registrar);

  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "simulate_team: " << e.what() << " (see simulate_team --help)\n";
    return kExitBadArguments;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }

  std::vector<std::string> errors = o->params.validate();
  if (compression != "none" && compression != "lz4" && compression != "bz2") {
    errors.push_back("compression = '" + compression +
                     "' is not allowed: allowed none | lz4 | bz2");
  }
  if (o->threads < 0)
    errors.push_back("threads = " + text(o->threads) + " is out of range: allowed >= 0");
  if (!errors.empty()) {
    for (const auto& error : errors) {
      // Errors start with the parameter's name: show the flag that sets it.
      const std::string name = error.substr(0, error.find_first_of(" ="));
      std::cerr << "simulate_team: --" << flagName(name) << ": " << error << '\n';
    }
    return kExitBadArguments;
  }
  o->bag_options.compression = compression == "lz4"   ? io::BagCompression::kLz4
                               : compression == "bz2" ? io::BagCompression::kBz2
                                                      : io::BagCompression::kNone;
  if (o->threads == 0) {
    o->threads = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  }
  for (int i = 1; i < argc; ++i) o->command_line += std::string(" ") + argv[i];
  return std::nullopt;
}

struct Results {
  std::unique_ptr<sim::Mission> mission;
  std::vector<io::RobotRecording> recordings;
  double seconds = 0.0;
};

/// Simulates and writes the mission, printing its world first; throws std::runtime_error (a
/// file that cannot be written).
Results run(const Options& o) {
  const auto started = std::chrono::steady_clock::now();
  std::filesystem::create_directories(o.out_dir);
  Results r;
  r.mission = std::make_unique<sim::Mission>(o.params);
  const auto& world = r.mission->world();
  std::printf(
      "simulate_team: %s %.0f x %.0f m (%zu boxes, %zu cylinders, %zu walls), "
      "%d robot(s), %.1f s, seed %d -> %s\n",
      world.kind().c_str(), world.bounds().x_max - world.bounds().x_min,
      world.bounds().y_max - world.bounds().y_min, world.boxes().size(), world.cylinders().size(),
      world.walls().size(), o.params.robots, o.params.duration_s, o.params.seed, o.out_dir.c_str());
  r.recordings = recordAll(*r.mission, o.out_dir, o.bag_options, o.threads);
  io::writeMissionFile(*r.mission, r.recordings, o.out_dir, o.command_line);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return r;
}

void report(const Options& o, const Results& results) {
  for (size_t i = 0; i < results.recordings.size(); ++i) {
    const auto& robot = results.mission->robots()[i];
    const auto& r = results.recordings[i];
    std::printf("  %-9s %-6s starts +%5.1f s  %6.1f m  %5lu scans  shared %3.0f %%  %s (%.0f MB)\n",
                robot.name.c_str(), robot.aerial ? "aerial" : "ground", robot.start_offset_s,
                robot.distance_m, static_cast<unsigned long>(r.scans),
                100.0 * robot.shared_fraction, r.bag_file.c_str(), r.bag_bytes / 1e6);
  }
  std::printf("simulate_team: wrote %s/mission.yaml in %.1f s\n", o.out_dir.c_str(),
              results.seconds);
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines appear as they are written
  return tools::runTool("simulate_team", argc, argv, parse, run, report);
}
