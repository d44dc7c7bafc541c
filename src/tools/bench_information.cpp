// bench_information: the occupancy map's costs on simulated VLP-16 keyframes in a mine (0.1 m
// voxel keyframes, as the Preprocessor makes them), at the map's resolution: ms per keyframe
// insertion, per mutual-information evaluation of a keyframe (CSQMI of its beams) and of a
// simulated measurement, per entropy-drop evaluation; then ms to rank N of L keyframes against
// a map holding a few of them, naive and lazy, and whether both choose the same keyframes; then
// CCIR's costs with all of them kept: ms to build one offer for each of two teammates (one of
// which holds a part already) and to choose the requests for an offer (CSQMI of each offered
// scan on the map). Prints JSON. Targets: MI <= 10 ms per scan, lazy ranking <= 200 ms, an offer
// <= 100 ms with 500 kept keyframes and 2 peers, requests <= 50 ms. Last, submaps: a map of
// every keyframe moved by a small correction, the ms to move its submaps against the ms its
// keyframes took to insert, and the MB of the map and of the submaps.
#include <chrono>
#include <cstdio>
#include <optional>
#include <random>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/scan_ranker.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"
#include "ccir_mapping/core/routing/ccir_broker.h"
#include "ccir_mapping/core/simulation/lidar_model.h"
#include "ccir_mapping/core/simulation/world_builder.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace info = core::information;
namespace sim = core::simulation;
namespace tools = ccir_mapping::tools;

namespace {

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

struct Keyframe {
  core::Pose3 pose;                              // sensor in the world
  pcl::PointCloud<pcl::PointXYZ> sensor_points;  // 0.1 m voxels, as the Mapper gets them
  pcl::PointCloud<pcl::PointXYZ> world_points;
};

/// `count` keyframes along the mine's drifts, sensor 0.5 m above the floor: at random places,
/// or (`step_m` > 0) along a random walk over the drifts, one every step_m.
std::vector<Keyframe> keyframes(const sim::World& world, int count, unsigned seed,
                                double step_m = 0.0) {
  const sim::LidarModel lidar{sim::LidarParams{}};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto& roads = world.roadMap();
  std::vector<Keyframe> result;
  const auto pick = [&](int node) {
    return roads.neighbours(node)[static_cast<std::size_t>(u(rng) * roads.neighbours(node).size()) %
                                  roads.neighbours(node).size()];
  };
  int a = 0;
  while (roads.neighbours(a).empty()) ++a;
  int b = pick(a);
  double along_m = 0.0;
  while (static_cast<int>(result.size()) < count) {
    Eigen::Vector2d xy;
    if (step_m > 0) {
      const double length = (roads.node(b) - roads.node(a)).norm();
      if (along_m > length) {
        along_m -= length;
        a = std::exchange(b, pick(b));
        continue;
      }
      xy = roads.node(a) + (along_m / length) * (roads.node(b) - roads.node(a));
      along_m += step_m;
    } else {
      a = static_cast<int>(u(rng) * roads.nodeCount()) % roads.nodeCount();
      if (roads.neighbours(a).empty()) continue;
      b = pick(a);
      xy = roads.node(a) + u(rng) * (roads.node(b) - roads.node(a));
    }
    Keyframe k;
    k.pose = Eigen::Translation3d(xy.x(), xy.y(), world.floorZ() + 0.5) *
             Eigen::AngleAxisd(2 * M_PI * u(rng), Eigen::Vector3d::UnitZ());
    const core::LidarScan scan = lidar.scan(
        world, 0, [&](double) { return k.pose; }, rng);
    pcl::PointCloud<pcl::PointXYZ> sensor;
    for (const auto& p : scan.points) sensor.push_back(pcl::PointXYZ(p.x, p.y, p.z));
    const auto kept = core::preprocess::voxelDownsample(sensor, 0.1);
    k.sensor_points = *kept;
    for (const auto& p : *kept) {
      const Eigen::Vector3d w = k.pose * p.getVector3fMap().cast<double>();
      k.world_points.push_back(pcl::PointXYZ(w.x(), w.y(), w.z()));
    }
    result.push_back(std::move(k));
  }
  return result;
}

struct Options {
  int candidates = 500;
  int choose = 10;
  int held = 20;
  int block_levels = 3;
  info::MapperParams map;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options("Usage: bench_information [options]\nPrints JSON.\n\nOptions",
                                  100);
  options.add_options()("help,h", "print this help and exit")(
      "candidates", po::value<int>(&o->candidates)->default_value(o->candidates),
      "L: keyframes to rank")("choose", po::value<int>(&o->choose)->default_value(o->choose),
                              "N: keyframes to choose")(
      "held", po::value<int>(&o->held)->default_value(o->held),
      "keyframes the receiver is believed to hold already")(
      "block-levels", po::value<int>(&o->block_levels)->default_value(o->block_levels),
      "the ranking counts coverage in blocks of 2^this voxels a side")(
      "resolution-m", po::value<double>(&o->map.resolution_m)->default_value(o->map.resolution_m),
      "map resolution [m]");
  if (const auto exit_code = tools::parseCommandLine("bench_information", options, argc, argv)) {
    return exit_code;
  }
  if (o->candidates < 1 || o->choose < 1 || o->held < 0 || !o->map.validate().empty()) {
    return tools::usageError("bench_information",
                             "need --candidates, --choose >= 1, --held >= 0 and a valid "
                             "--resolution-m");
  }
  return std::nullopt;
}

/// Milliseconds per operation, and what the ranking and routing chose.
struct Results {
  double points_per_keyframe = 0, insert_ms = 0;
  double scan_mi_ms = 0, simulated_mi_ms = 0, gains_ms = 0, blocks_per_keyframe = 0;
  std::size_t scan_mi_beams = 0;
  double naive_ms = 0, lazy_ms = 0;
  std::size_t naive_evaluations = 0, lazy_evaluations = 0;
  bool same_choice = false;
  double footprint_ms = 0, offer_ms = 0, requests_ms = 0;
  std::size_t offered = 0, offered_to_requester = 0, requested = 0;
  double insert_all_ms = 0, reanchor_ms = 0, map_mb = 0, submap_mb = 0;
  std::size_t submaps_moved = 0;
};

/// The map's costs on `frames`: the first `held` make the receiver's map, the rest are the
/// candidates.
void measureMap(const Options& o, const std::vector<Keyframe>& frames, info::OccupancyMap& map,
                Results& r) {
  std::size_t points = 0;
  for (int i = 0; i < o.held; ++i) {
    const auto start = std::chrono::steady_clock::now();
    map.insert(frames[i].sensor_points, frames[i].pose);  // the Mapper's call
    r.insert_ms += millisecondsSince(start);
    points += frames[i].world_points.size();
  }
  if (o.held > 0) {
    r.points_per_keyframe = double(points) / o.held;
    r.insert_ms /= o.held;
  }
  // Per candidate: mutual information of its beams, of a simulated measurement at its pose,
  // and the voxel gains the ranking needs (the update and the entropy drop of each voxel).
  std::vector<std::vector<info::VoxelGain>> gains;
  for (int i = o.held; i < o.held + o.candidates; ++i) {
    auto start = std::chrono::steady_clock::now();
    volatile double mi = map.scanCsqmi(frames[i].world_points, frames[i].pose.translation());
    r.scan_mi_ms += millisecondsSince(start);
    start = std::chrono::steady_clock::now();
    mi = map.simulatedCsqmi(frames[i].pose);
    r.simulated_mi_ms += millisecondsSince(start);
    (void)mi;
    start = std::chrono::steady_clock::now();
    gains.push_back(info::coarsened(
        map.voxelGains(map.computeUpdate(frames[i].world_points, frames[i].pose.translation())),
        o.block_levels));
    r.gains_ms += millisecondsSince(start);
    r.blocks_per_keyframe += double(gains.back().size());
  }
  const double n = o.candidates;
  r.scan_mi_ms /= n;
  r.simulated_mi_ms /= n;
  r.gains_ms /= n;
  r.blocks_per_keyframe /= n;
  r.scan_mi_beams =
      frames[o.held].world_points.size() / static_cast<std::size_t>(o.map.scan_beam_step);

  const info::ScanRanker ranker(gains);
  auto start = std::chrono::steady_clock::now();
  const auto naive = ranker.rankNaive(static_cast<std::size_t>(o.choose));
  r.naive_ms = millisecondsSince(start);
  r.naive_evaluations = ranker.evaluations();
  start = std::chrono::steady_clock::now();
  const auto lazy = ranker.rankLazy(static_cast<std::size_t>(o.choose));
  r.lazy_ms = millisecondsSince(start);
  r.lazy_evaluations = ranker.evaluations();
  r.same_choice = naive.size() == lazy.size();
  for (std::size_t i = 0; r.same_choice && i < naive.size(); ++i) {
    r.same_choice = naive[i].index == lazy[i].index;
  }
}

/// CCIR's costs: every keyframe kept with its footprint; teammate robot_c already holds the
/// first quarter; the requester scores an offer of 10 on `map`.
void measureRouting(const Options& o, const std::vector<Keyframe>& frames,
                    const info::OccupancyMap& map, Results& r) {
  const int kept = o.held + o.candidates;
  core::routing::CcirBroker broker("robot_a", {"robot_b", "robot_c"},
                                   core::routing::BrokerParams{});
  const info::OccupancyMap empty(o.map);
  for (int i = 0; i < kept; ++i) {
    pcl::PointCloud<pcl::PointXYZ> sensor;
    const core::Pose3 to_sensor = frames[i].pose.inverse();
    for (const auto& p : frames[i].world_points) {
      const Eigen::Vector3d q = to_sensor * p.getVector3fMap().cast<double>();
      sensor.push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
    }
    const auto start = std::chrono::steady_clock::now();
    auto footprint = core::routing::CcirBroker::footprint(empty, sensor, frames[i].pose);
    r.footprint_ms += millisecondsSince(start);
    broker.addKeyframe(i, i, frames[i].pose, 60000, std::move(footprint));
    broker.setCorrespondences("robot_b", i, i % 7);
  }
  r.footprint_ms /= kept;
  const core::routing::LinkState link{true, 150000.0, 300000.0, 0};
  broker.setLink("robot_c", link);
  const auto first = broker.makeOffer("robot_c", 0.0);
  core::routing::Request take{"robot_c", "robot_a", first ? first->sequence : 0, {}};
  for (int round = 0; round < kept / 4 && first; ++round) {
    broker.setLink("robot_c", link);
    const auto offer = broker.makeOffer("robot_c", 0.0);
    if (!offer) break;
    take.offer_sequence = offer->sequence;
    take.ids = {offer->scans.front().id};
    broker.onRequest(take, 0.0);
  }
  for (const char* peer : {"robot_b", "robot_c"}) {
    broker.setLink(peer, link);
    const auto start = std::chrono::steady_clock::now();
    const auto offer = broker.makeOffer(peer, 1.0);
    r.offer_ms += millisecondsSince(start) / 2;
    r.offered += offer ? offer->scans.size() : 0;
  }
  core::routing::CcirBroker requester("robot_b", {"robot_a"}, core::routing::BrokerParams{});
  requester.setLink("robot_a", link);
  requester.setTeamTransform("robot_a", core::Pose3::Identity());
  core::routing::Offer offer{"robot_a", "robot_b", 1, {}};
  for (int i = 0; i < 10; ++i) {
    core::routing::OfferEntry entry;
    entry.id = i;
    entry.pose = frames[o.held + i].pose;
    entry.correspondences = i;
    entry.size_bytes = 60000;
    offer.scans.push_back(entry);
  }
  requester.onOffer(offer);
  const auto start = std::chrono::steady_clock::now();
  const auto requests = requester.chooseRequests(
      [&](const core::Pose3& sensor_pose) { return map.simulatedCsqmi(sensor_pose); }, 0.0);
  r.requests_ms = millisecondsSince(start);
  r.offered_to_requester = offer.scans.size();
  r.requested = requests.empty() ? 0 : requests.front().ids.size();
}

/// What following a correction costs: a map of keyframes 1 m apart along a walk through the
/// drifts (submaps of submap_scans) moved by a loop closure's small correction (0.3 m, 1.5
/// degrees) against inserting every keyframe again at the new poses, as a rebuild would.
void measureSubmaps(const Options& o, const std::vector<Keyframe>& frames, Results& r) {
  info::MapperStage stage("robot_a", o.map);
  std::vector<std::pair<core::Stamp, core::Pose3>> corrected;
  const core::Pose3 correction = Eigen::Translation3d(0.3, 0.0, 0.0) *
                                 Eigen::AngleAxisd(1.5 * M_PI / 180, Eigen::Vector3d::UnitZ());
  auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto stamp = static_cast<core::Stamp>(i + 1);
    stage.addOwn(stamp, std::make_shared<const info::Cloud>(frames[i].sensor_points),
                 frames[i].pose);
    corrected.emplace_back(stamp, correction * frames[i].pose);
  }
  r.insert_all_ms = millisecondsSince(start);
  stage.setOptimizedPoses(corrected);
  start = std::chrono::steady_clock::now();
  r.submaps_moved = stage.followPoses(0.0);
  r.reanchor_ms = millisecondsSince(start);
  const auto stats = stage.stats();
  r.map_mb = stats.map_mb;
  r.submap_mb = stats.submap_mb;
}

Results run(const Options& o) {
  sim::WorldParams world_params;
  world_params.mine_pillars_x = 3;
  world_params.mine_pillars_y = 3;
  const sim::World world = sim::buildWorld(world_params, 7);
  const auto frames = keyframes(world, o.candidates + o.held, 5);
  Results r;
  info::OccupancyMap map(o.map);  // the receiver's believed map
  measureMap(o, frames, map, r);
  measureRouting(o, frames, map, r);
  measureSubmaps(o, keyframes(world, o.held + o.candidates, 5, 1.0), r);
  return r;
}

void report(const Options& o, const Results& r) {
  std::printf(
      "{\n  \"benchmark\": \"information\",\n  \"resolution_m\": %.2f,\n"
      "  \"points_per_keyframe\": %.0f,\n  \"insert_ms_per_keyframe\": %.1f,\n"
      "  \"scan_mi_ms\": %.2f,\n  \"scan_mi_beams\": %zu,\n  \"simulated_mi_ms\": %.2f,\n"
      "  \"simulated_mi_beams\": %d,\n  \"mi_target_ms\": 10,\n"
      "  \"voxel_gains_ms_per_keyframe\": %.1f,\n  \"blocks_per_keyframe\": %.0f,\n"
      "  \"rank\": {\"choose\": %d, \"of\": %d, \"naive_ms\": %.1f, \"lazy_ms\": %.1f, "
      "\"lazy_target_ms\": 200, \"speedup\": %.1f, \"naive_evaluations\": %zu, "
      "\"lazy_evaluations\": %zu, \"same_choice\": %s},\n"
      "  \"routing\": {\"kept\": %d, \"peers\": 2, \"footprint_ms_per_keyframe\": %.1f, "
      "\"offer_ms_per_peer\": %.1f, \"offer_target_ms\": 100, \"scans_offered\": %zu, "
      "\"requests_ms\": %.1f, \"requests_target_ms\": 50, \"offered_to_requester\": %zu, "
      "\"requested\": %zu},\n"
      "  \"submaps\": {\"keyframes\": %d, \"insert_ms\": %.0f, \"moved\": %zu, "
      "\"reanchor_ms\": %.0f, \"speedup\": %.1f, \"map_mb\": %.1f, \"submap_mb\": %.1f}\n}\n",
      o.map.resolution_m, r.points_per_keyframe, r.insert_ms, r.scan_mi_ms, r.scan_mi_beams,
      r.simulated_mi_ms, static_cast<int>(16 * std::ceil(360 / o.map.simulated_azimuth_step_deg)),
      r.gains_ms, r.blocks_per_keyframe, o.choose, o.candidates, r.naive_ms, r.lazy_ms,
      r.naive_ms / r.lazy_ms, r.naive_evaluations, r.lazy_evaluations,
      r.same_choice ? "true" : "false", o.held + o.candidates, r.footprint_ms, r.offer_ms,
      r.offered, r.requests_ms, r.offered_to_requester, r.requested, o.held + o.candidates,
      r.insert_all_ms, r.submaps_moved, r.reanchor_ms, r.insert_all_ms / r.reanchor_ms, r.map_mb,
      r.submap_mb);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  const Results results = run(options);
  report(options, results);
  return results.same_choice ? 0 : 1;
}
