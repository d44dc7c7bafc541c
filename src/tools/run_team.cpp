// run_team: a whole team in simulated time, without ROS (core/runner/team_runner.h): every robot's
// stages as its nodelets chain them, links through the Bridge's scheduler and token buckets over
// an emulated radio. A run is determined by its flags (the mission's seed included) and is the
// same for any --threads. Progress on stderr; a summary as JSON on stdout; with --out,
// DIR/report.json with the time series too, in the layout of the demo's report.json
// (ccir_mapping.demo_page and compare_routing read either). Exit codes: 0 done, 1 failed, 2
// bad arguments.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <thread>

#include <jsoncpp/json/json.h>
#include <yaml-cpp/yaml.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/runner/team_runner.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/yaml_params.h"
#include "command_line.h"
#include "flag_registrar.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
namespace core = ccir_mapping::core;
namespace runner = ccir_mapping::core::runner;

namespace {

/// A transform within this of the truth is correct (as in ccir_mapping.demo_summary).
constexpr double kCorrectM = 0.3, kCorrectDeg = 2.0;

struct Options {
  runner::RunnerParams params;
  std::string mission_dir;
  std::string config_file;
  std::string model_dir = CCIR_DEFAULT_MODEL_DIR;
  std::string out_dir;
  int threads = 1;
  double progress_period_s = 10.0;
};

/// Sets the mission flags from the command simulate_team recorded in DIR/mission.yaml; the
/// error, if it cannot.
std::optional<std::string> readMissionFlags(const std::string& dir,
                                            const po::options_description& mission_flags) {
  std::string command;
  try {
    command = YAML::LoadFile(dir + "/mission.yaml")["command"].as<std::string>();
  } catch (const std::exception& e) {
    return "cannot read the command of " + dir + "/mission.yaml: " + e.what();
  }
  std::istringstream words(command);
  std::vector<std::string> tokens{std::istream_iterator<std::string>(words), {}};
  if (tokens.empty() || tokens.front() != "simulate_team") {
    return dir + "/mission.yaml: not a command of simulate_team: " + command;
  }
  tokens.erase(tokens.begin());
  try {  // only the mission's flags; simulate_team's others (--out, --compression) do not matter
    po::variables_map parsed;
    po::store(po::command_line_parser(tokens).options(mission_flags).allow_unregistered().run(),
              parsed);
    po::notify(parsed);
  } catch (const po::error& e) {
    return dir + "/mission.yaml: " + e.what();
  }
  return std::nullopt;
}

/// The stages' parameters from a robot configuration file in config/robot.yaml's layout, read
/// with the nodelets' own loaders (its bridge section is not read: the link flags set it); the
/// errors, each naming its section and key.
std::vector<std::string> readStageConfig(const std::string& path, runner::RunnerParams& p) {
  namespace rp = ccir_mapping::ros_params;
  YAML::Node file;
  try {
    file = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return {"config = '" + path + "' cannot be read: " + e.what()};
  }
  std::vector<std::string> errors;
  const auto section = [&](const char* name, auto settings, auto& params) {
    settings.core = params;
    rp::ParamReader reader(file[name] ? rp::toXmlRpc(file[name]) : XmlRpc::XmlRpcValue(), name);
    rp::load(reader, settings);
    for (const auto& error : reader.errors()) errors.push_back(std::string(name) + "/" + error);
    for (const auto& key : reader.unknownKeys()) {
      errors.push_back(std::string(name) + "/" + key + " in " + path + " is not a parameter");
    }
    params = settings.core;
  };
  section("preprocessor", rp::PreprocessorSettings{}, p.preprocessor);
  section("matcher", rp::MatcherSettings{}, p.matcher);
  section("backend", rp::BackendSettings{}, p.backend);
  section("mapper", rp::MapperSettings{}, p.mapper);
  section("broker", rp::BrokerSettings{}, p.broker);
  return errors;
}

/// The value of --config, looked for before the other flags take their defaults from it.
std::string configFlag(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--config" && i + 1 < argc) return argv[i + 1];
    if (arg.rfind("--config=", 0) == 0) return arg.substr(9);
  }
  return {};
}

std::optional<int> parse(int argc, char** argv, Options* o) {
  auto& p = o->params;
  o->config_file = configFlag(argc, argv);
  if (!o->config_file.empty()) {
    const auto errors = readStageConfig(o->config_file, p);
    for (const auto& error : errors) std::cerr << "run_team: --config: " << error << '\n';
    if (!errors.empty()) return 2;
    if (!p.matcher.model_dir.empty()) o->model_dir = p.matcher.model_dir;
  }
  // Defaults that differ from the stages' own, and why: solves are bounded by iterations rather
  // than wall time, so a run does not depend on the machine's speed; the radio carries whatever
  // the budget lets through, as the loopback TCP of the bridged demo does.
  p.backend.max_solve_time_s = 60.0;
  p.radio.rate_bytes_per_s = 1e9;
  std::string mode = core::routing::toString(p.broker.mode);
  std::string topology = runner::toString(p.topology);
  double total_budget = 0.0;
  po::options_description options(
      "Usage: run_team [--world mine] [--robots 3] [--duration 120] [--seed 7] [--mode ccir]\n"
      "                [--budget-bytes-per-s 150000] [--threads N] [--out DIR]\n\n"
      "Runs a simulated team mission through every robot's pipeline (preprocessing, place\n"
      "recognition, team pose graph, map, CCIR routing) with links through the bridge's\n"
      "scheduler and token buckets, in simulated time. The stages take the defaults of\n"
      "config/robot.yaml (or of --config). A flag may be shortened while it stays\n"
      "unambiguous.\n\n"
      "Options",
      110);
  options.add_options()("help,h", "print this help and exit")(
      "mission", po::value<std::string>(&o->mission_dir)->value_name("dir"),
      "run the mission simulate_team wrote to DIR (its flags, from DIR/mission.yaml, make the "
      "same mission again) instead of the mission flags below")(
      "config", po::value<std::string>(&o->config_file)->value_name("file"),
      "the stages' parameters from a robot configuration file (config/robot.yaml's sections "
      "preprocessor, matcher, backend, mapper, broker; not bridge, which the link flags set, "
      "nor backend/max_solve_time_s, which --max-solve-time-s sets); the flags' defaults "
      "otherwise")("out", po::value<std::string>(&o->out_dir)->value_name("dir"),
                   "write DIR/report.json (summary and time series)")(
      "model-dir", po::value<std::string>(&o->model_dir)->default_value(o->model_dir),
      "place-recognition model (train_place_model output)")(
      "threads", po::value<int>(&o->threads)->default_value(o->threads),
      "robots handled in parallel (results do not depend on it); 0: one per core")(
      "mode", po::value<std::string>(&mode)->default_value(mode),
      "what robots send: ccir | fixed_rate | all")(
      "every-n",
      po::value<int>(&p.broker.fixed_rate_every_n)->default_value(p.broker.fixed_rate_every_n),
      "fixed_rate: every n-th keyframe")(
      "budget-bytes-per-s",
      po::value<double>(&p.bridge.budget_bytes_per_s)->default_value(p.bridge.budget_bytes_per_s),
      "bytes/s on each link, frame headers included")(
      "total-budget-bytes-per-s", po::value<double>(&total_budget)->default_value(0.0),
      "bytes/s over all of a robot's links together; 0: the same as --budget-bytes-per-s")(
      "radio-rate-bytes-per-s",
      po::value<double>(&p.radio.rate_bytes_per_s)->default_value(p.radio.rate_bytes_per_s),
      "the radio's own rate under the budget")(
      "radio-delay-s", po::value<double>(&p.radio.delay_s)->default_value(p.radio.delay_s),
      "one-way delay")(
      "radio-jitter-s", po::value<double>(&p.radio.jitter_s)->default_value(p.radio.jitter_s),
      "delay jitter")("radio-loss", po::value<double>(&p.radio.loss)->default_value(p.radio.loss),
                      "share of frames lost once (each arrives a retransmission later)")(
      "topology", po::value<std::string>(&topology)->default_value(topology),
      "which robots are linked: all_pairs | radio_range")(
      "radio-range-m", po::value<double>(&p.radio_range_m)->default_value(p.radio_range_m),
      "radio_range: largest distance of a link, m")("line-of-sight",
                                                    po::bool_switch(&p.radio_needs_line_of_sight),
                                                    "radio_range: walls block links")(
      "max-peers", po::value<int>(&p.max_peers)->default_value(p.max_peers),
      "radio_range: most teammates linked at once (the nearest); 0: no bound")(
      "step-s", po::value<double>(&p.step_s)->default_value(p.step_s),
      "simulated-time step (a message waits up to one step)")(
      "series-period-s", po::value<double>(&p.series_period_s)->default_value(p.series_period_s),
      "period of the time series")(
      "link-stats-period-s",
      po::value<double>(&p.bridge.stats_period_s)->default_value(p.bridge.stats_period_s),
      "how often the Broker learns its links' state (the Bridge's LinkStats period)")(
      "max-solve-time-s",
      po::value<double>(&p.backend.max_solve_time_s)->default_value(p.backend.max_solve_time_s),
      "wall-time bound of one optimisation (the Backend's is 0.5 s; a run with a bound that "
      "binds depends on the machine)")(
      "progress-period-s", po::value<double>(&o->progress_period_s)->default_value(10.0),
      "mission seconds between progress lines on stderr");
  po::options_description mission_flags("Mission (simulate_team's flags)", 110);
  tools::FlagRegistrar registrar(&mission_flags);
  core::simulation::MissionParams::fields(p.mission, registrar);
  options.add(mission_flags);
  po::variables_map arguments;
  if (const auto exit_code = tools::parseCommandLine("run_team", options, argc, argv, &arguments)) {
    return exit_code;
  }
  std::vector<std::string> errors;
  if (!o->mission_dir.empty()) {
    for (const auto& flag : mission_flags.options()) {
      if (!arguments[flag->long_name()].defaulted()) {
        return tools::usageError(
            "run_team", "--" + flag->long_name() + " with --mission: the mission's flags decide");
      }
    }
    if (const auto error = readMissionFlags(o->mission_dir, mission_flags)) {
      return tools::usageError("run_team", "--mission: " + *error);
    }
  }
  if (const auto parsed = core::routing::parseRoutingMode(mode)) {
    p.broker.mode = *parsed;
  } else {
    errors.push_back("mode = '" + mode + "' is not allowed: allowed ccir | fixed_rate | all");
  }
  if (const auto parsed = runner::parseTopology(topology)) {
    p.topology = *parsed;
  } else {
    errors.push_back("topology = '" + topology + "' is not allowed: allowed " +
                     std::string(runner::kTopologyChoices));
  }
  p.bridge.total_budget_bytes_per_s =
      total_budget > 0.0 ? total_budget : p.bridge.budget_bytes_per_s;
  p.radio.seed = static_cast<std::uint64_t>(p.mission.seed);
  p.matcher.model_dir = o->model_dir;
  if (o->threads < 0) errors.push_back("threads = " + tools::text(o->threads) + ": allowed >= 0");
  if (o->threads == 0)
    o->threads = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
  const auto more = p.validate();
  errors.insert(errors.end(), more.begin(), more.end());
  for (const auto& error : errors) {
    std::cerr << "run_team: --" << tools::flagName(error.substr(0, error.find_first_of(" =")))
              << ": " << error << '\n';
  }
  return errors.empty() ? std::nullopt : std::optional<int>(2);
}

runner::TeamResult run(const Options& o) {
  const auto model = core::place_recognition::PlaceModel::load(o.model_dir);
  const auto& m = o.params.mission;
  std::fprintf(
      stderr, "run_team: %s, %d robot(s), %.0f s, seed %d, %s, %.0f B/s per link, %d thread(s)\n",
      m.world.world.c_str(), m.robots, m.duration_s, m.seed,
      core::routing::toString(o.params.broker.mode), o.params.bridge.budget_bytes_per_s, o.threads);
  double next_progress = o.progress_period_s;
  runner::TeamRunner team(o.params, model, o.threads);
  return team.run([&](double done_s, double total_s, double wall_s) {
    if (done_s + 1e-9 < next_progress && done_s + 1e-9 < total_s) return;
    next_progress += o.progress_period_s;
    std::fprintf(stderr, "run_team: %6.1f / %.0f mission s in %.1f s wall (%.2f x real time)\n",
                 done_s, total_s, wall_s, done_s / std::max(wall_s, 1e-9));
  });
}

double round3(double x) { return std::round(x * 1e3) / 1e3; }

Json::Value transformJson(const std::string& peer, const runner::RobotResult& r) {
  Json::Value t;
  t["peer"] = peer;
  const auto& last = r.transforms.at(peer);
  t["valid"] = last.valid;
  t["inliers"] = last.inliers;
  for (const auto& estimate : r.team) {
    if (estimate.peer == peer) t["candidates"] = estimate.candidates;
  }
  if (last.valid) {
    t["error_m"] = round3(last.error_m);
    t["error_deg"] = round3(last.error_deg);
  }
  Json::Value series(Json::arrayValue);
  const auto it = r.transform_series.find(peer);
  for (const auto& s :
       it == r.transform_series.end() ? std::vector<runner::TransformSample>{} : it->second) {
    if (!s.valid) continue;
    Json::Value row(Json::arrayValue);
    row.append(s.t_s);
    row.append(round3(s.error_m));
    row.append(round3(s.error_deg));
    series.append(row);
    if (!t.isMember("first_valid_s")) {
      t["first_valid_s"] = s.t_s;
      t["first_valid_error"].append(round3(s.error_m));
      t["first_valid_error"].append(round3(s.error_deg));
    }
    if (!t.isMember("first_correct_s") && s.error_m <= kCorrectM && s.error_deg <= kCorrectDeg) {
      t["first_correct_s"] = s.t_s;
    }
  }
  t["error_series"] = series;
  return t;
}

Json::Value robotJson(const runner::RobotResult& r, const runner::RunnerParams& p, bool series) {
  Json::Value j;
  j["name"] = r.name;
  j["keyframes"] = Json::UInt64(r.keyframes);
  j["scans_missed"] = 0;
  j["scans_dropped"] = Json::UInt64(r.dropped_scans);
  j["cpu_s"]["pipeline"] = round3(r.pipeline_cpu_s);
  j["cpu_s"]["recording_and_preprocessing"] = round3(r.recording_cpu_s);
  for (const auto& [stage, s] : r.stage_cpu_s) j["stage_cpu_s"][stage] = round3(s);
  j["ate_m"]["optimised"] = round3(r.ate_m);
  j["ate_m"]["odometry"] = round3(r.odometry_ate_m);
  j["loop_closures"]["own"] = r.own_loops;
  j["loop_closures"]["with_teammates"] = r.inter_robot_loops;
  j["map"]["known_volume_m3"] = round3(r.map.known_volume_m3);
  j["map"]["entropy_bits"] = round3(r.map.entropy_bits);
  j["map"]["keyframes"] = Json::UInt64(r.map.keyframes);
  j["map"]["peer_scans"] = Json::UInt64(r.map.peer_scans);
  j["map"]["submaps"] = Json::UInt64(r.map.submaps);
  j["map"]["settled_scans"] = Json::UInt64(r.map.settled_scans);
  j["map"]["submap_moves"] = Json::UInt64(r.map.submap_moves);
  j["map"]["reintegrations"] = Json::UInt64(r.map.reintegrations);
  j["map"]["map_mb"] = round3(r.map.map_mb);
  j["map"]["submap_mb"] = round3(r.map.submap_mb);
  j["broker"]["scans_sent"] = Json::UInt64(r.broker.scans_sent);
  j["broker"]["scans_received"] = Json::UInt64(r.broker.scans_received);
  j["broker"]["features_sent"] = Json::UInt64(r.broker.features_sent);
  for (const auto& [kind, n] : r.refusals) j["refused"][kind] = Json::UInt64(n);
  for (const auto& [peer, c] : r.broker.peers) {
    Json::Value& p = j["routing"][peer];
    p["offers_sent"] = Json::UInt64(c.offers_sent);
    p["scans_offered"] = Json::UInt64(c.scans_offered);
    p["scans_requested_by_peer"] = Json::UInt64(c.scans_requested_by_peer);
    p["scans_sent"] = Json::UInt64(c.scans_sent);
    p["scan_bytes_sent"] = Json::UInt64(c.scan_bytes_sent);
    p["scans_received"] = Json::UInt64(c.scans_received);
    p["control_bytes_sent"] = Json::UInt64(c.control_bytes_sent);
  }
  j["links"] = Json::objectValue;
  for (const auto& [peer, c] : r.links) {
    Json::Value& l = j["links"][peer];
    l["bytes_sent"] = Json::UInt64(c.bytes_sent);
    l["messages_sent"] = Json::UInt64(c.messages_sent);
    l["frames_sent"] = Json::UInt64(c.frames_sent);
    l["dropped_queue_full"] = Json::UInt64(c.dropped_queue_full);
    l["budget_bytes_per_s"] = p.bridge.budget_bytes_per_s;
  }
  j["team_frames"] = Json::arrayValue;
  for (const auto& [peer, last] : r.transforms) j["team_frames"].append(transformJson(peer, r));
  if (!series) return j;
  j["link_series"] = Json::objectValue;
  for (const auto& [peer, rows] : r.bytes_series) {
    Json::Value& l = j["link_series"][peer];
    double peak = 0.0;
    for (std::size_t k = 0; k < rows.size(); ++k) {
      Json::Value row(Json::arrayValue);
      row.append(rows[k].first);
      row.append(Json::UInt64(rows[k].second));
      l["cumulative_bytes"].append(row);
      if (k > 0) {
        peak = std::max(peak, double(rows[k].second - rows[k - 1].second) / 1e3 /
                                  (rows[k].first - rows[k - 1].first));
      }
    }
    l["peak_kb_per_s"] = std::round(peak * 10) / 10;
  }
  j["map_series"] = Json::arrayValue;
  for (const auto& row : r.map_series) {
    Json::Value v(Json::arrayValue);
    for (const double x : row) v.append(round3(x));
    j["map_series"].append(v);
  }
  j["cpu_series"] = Json::arrayValue;
  for (const auto& [t, cpu] : r.cpu_series) {
    Json::Value v(Json::arrayValue);
    v.append(t);
    v.append(round3(cpu));
    j["cpu_series"].append(v);
  }
  j["work_series"] = Json::arrayValue;
  for (const auto& w : r.work_series) {
    Json::Value v;
    v["t"] = w.t;
    v["keyframes"] = Json::UInt64(w.keyframes);
    v["places"] = Json::UInt64(w.places);
    v["verifications"] = Json::UInt64(w.verifications);
    for (const auto& [stage, s] : w.stage_cpu_s) v["stage_cpu_s"][stage] = round3(s);
    j["work_series"].append(v);
  }
  j["closure_waits"] = Json::arrayValue;
  for (const auto& [t, waited] : r.closure_waits) {
    Json::Value v(Json::arrayValue);
    v.append(round3(t));
    v.append(round3(waited));
    j["closure_waits"].append(v);
  }
  return j;
}

Json::Value reportJson(const Options& o, const runner::TeamResult& result, bool series) {
  const auto& p = o.params;
  Json::Value j;
  j["tool"] = "run_team";
  j["world"]["kind"] = p.mission.world.world;
  j["seed"] = p.mission.seed;
  j["duration_s"] = result.duration_s;
  j["playback_rate"] = Json::nullValue;
  j["mode"] = core::routing::toString(p.broker.mode);
  if (p.broker.mode == core::routing::RoutingMode::kFixedRate) {
    j["every_n"] = p.broker.fixed_rate_every_n;
  }
  j["budget_bytes_per_s"] = p.bridge.budget_bytes_per_s;
  j["topology"] = runner::toString(p.topology);
  j["threads"] = o.threads;
  j["wall_s"] = round3(result.wall_s);
  j["cpu_s"] = round3(result.cpu_s);
  // The speed target: robot-seconds of mission per core-second.
  j["robot_s_per_cpu_s"] =
      round3(result.duration_s * double(result.robots.size()) / std::max(result.cpu_s, 1e-9));
  std::uint64_t peak_rss = 0;
  for (const auto& [t, rss] : result.memory_series) peak_rss = std::max(peak_rss, rss);
  j["peak_resident_mb"] = round3(double(peak_rss) / 1e6);
  for (const auto& [link, s] : result.link_up_s) j["link_up_s"][link] = round3(s);
  j["robots"] = Json::arrayValue;
  for (const auto& r : result.robots) j["robots"].append(robotJson(r, p, series));
  if (series) {
    j["memory_series"] = Json::arrayValue;
    for (const auto& [t, rss] : result.memory_series) {
      Json::Value v(Json::arrayValue);
      v.append(t);
      v.append(Json::UInt64(rss));
      j["memory_series"].append(v);
    }
  }
  return j;
}

void report(const Options& o, const runner::TeamResult& result) {
  Json::StreamWriterBuilder writer;
  writer["indentation"] = "  ";
  writer["precision"] = 6;
  if (!o.out_dir.empty()) {
    std::filesystem::create_directories(o.out_dir);
    const std::string path = o.out_dir + "/report.json";
    std::ofstream(path) << Json::writeString(writer, reportJson(o, result, true)) << '\n';
    std::fprintf(stderr, "run_team: wrote %s\n", path.c_str());
  }
  std::cout << Json::writeString(writer, reportJson(o, result, false)) << std::endl;
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("run_team", argc, argv, parse, run, report);
}
