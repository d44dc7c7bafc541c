// bench_information: the occupancy map's costs on simulated VLP-16 keyframes in a mine (0.1 m
// voxel keyframes, as the Preprocessor makes them), at the map's resolution: ms per keyframe
// insertion, per mutual-information evaluation of a keyframe (CSQMI of its beams) and of a
// simulated measurement, per entropy-drop evaluation; then ms to rank N of L keyframes against
// a map holding a few of them, naive and lazy, and whether both choose the same keyframes; then
// CCIR's costs with all of them kept: ms to build one offer for each of two teammates (one of
// which holds a part already) and to choose the requests for an offer (CSQMI of each offered
// scan on the map). Prints JSON. Targets: MI <= 10 ms per scan, lazy ranking <= 200 ms, an offer
// <= 100 ms with 500 kept keyframes and 2 peers, requests <= 50 ms.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/information/occupancy_map.h"
#include "ccir_mapping/core/information/scan_ranker.h"
#include "ccir_mapping/core/preprocess/voxel_downsample.h"
#include "ccir_mapping/core/routing/ccir_broker.h"
#include "ccir_mapping/core/simulation/lidar_model.h"
#include "ccir_mapping/core/simulation/world_builder.h"

namespace po = boost::program_options;
namespace core = ccir_mapping::core;
namespace info = core::information;
namespace sim = core::simulation;

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

/// `count` keyframes at random places along the mine's drifts, sensor 0.5 m above the floor.
std::vector<Keyframe> keyframes(const sim::World& world, int count, unsigned seed) {
  const sim::LidarModel lidar{sim::LidarParams{}};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto& roads = world.roadMap();
  std::vector<Keyframe> result;
  while (static_cast<int>(result.size()) < count) {
    const int a = static_cast<int>(u(rng) * roads.nodeCount()) % roads.nodeCount();
    if (roads.neighbours(a).empty()) continue;
    const int b =
        roads.neighbours(a)[static_cast<std::size_t>(u(rng) * roads.neighbours(a).size()) %
                            roads.neighbours(a).size()];
    const Eigen::Vector2d xy = roads.node(a) + u(rng) * (roads.node(b) - roads.node(a));
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

}  // namespace

int main(int argc, char** argv) {
  int candidates = 500;
  int choose = 10;
  int held = 20;
  int block_levels = 3;
  info::MapperParams params;
  po::options_description options("Usage: bench_information [options]\nPrints JSON.\n\nOptions",
                                  100);
  options.add_options()("help,h", "print this help and exit")(
      "candidates", po::value<int>(&candidates)->default_value(candidates), "L: keyframes to rank")(
      "choose", po::value<int>(&choose)->default_value(choose), "N: keyframes to choose")(
      "held", po::value<int>(&held)->default_value(held),
      "keyframes the receiver is believed to hold already")(
      "block-levels", po::value<int>(&block_levels)->default_value(block_levels),
      "the ranking counts coverage in blocks of 2^this voxels a side")(
      "resolution-m", po::value<double>(&params.resolution_m)->default_value(params.resolution_m),
      "map resolution [m]");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "bench_information: " << e.what() << '\n';
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  if (candidates < 1 || choose < 1 || held < 0 || !params.validate().empty()) {
    std::cerr << "bench_information: need --candidates, --choose >= 1, --held >= 0 and a valid "
                 "--resolution-m\n";
    return 2;
  }
  sim::WorldParams world_params;
  world_params.mine_pillars_x = 3;
  world_params.mine_pillars_y = 3;
  const sim::World world = sim::buildWorld(world_params, 7);
  const auto frames = keyframes(world, candidates + held, 5);

  // The receiver's believed map: the first `held` keyframes.
  info::OccupancyMap map(params);
  double insert_ms = 0;
  std::size_t points = 0;
  for (int i = 0; i < held; ++i) {
    const auto start = std::chrono::steady_clock::now();
    map.insert(frames[i].sensor_points, frames[i].pose);  // the Mapper's call
    insert_ms += millisecondsSince(start);
    points += frames[i].world_points.size();
  }

  // Per candidate: mutual information of its beams, of a simulated measurement at its pose,
  // and the voxel gains the ranking needs (the update and the entropy drop of each voxel).
  double scan_mi_ms = 0;
  double simulated_mi_ms = 0;
  double gains_ms = 0;
  std::vector<std::vector<info::VoxelGain>> gains;
  for (int i = held; i < held + candidates; ++i) {
    auto start = std::chrono::steady_clock::now();
    volatile double mi = map.scanCsqmi(frames[i].world_points, frames[i].pose.translation());
    scan_mi_ms += millisecondsSince(start);
    start = std::chrono::steady_clock::now();
    mi = map.simulatedCsqmi(frames[i].pose);
    simulated_mi_ms += millisecondsSince(start);
    (void)mi;
    start = std::chrono::steady_clock::now();
    gains.push_back(info::coarsened(
        map.voxelGains(map.computeUpdate(frames[i].world_points, frames[i].pose.translation())),
        block_levels));
    gains_ms += millisecondsSince(start);
  }
  std::size_t voxels = 0;
  for (const auto& g : gains) voxels += g.size();

  const info::ScanRanker ranker(gains);
  auto start = std::chrono::steady_clock::now();
  const auto naive = ranker.rankNaive(static_cast<std::size_t>(choose));
  const double naive_ms = millisecondsSince(start);
  const std::size_t naive_evaluations = ranker.evaluations();
  start = std::chrono::steady_clock::now();
  const auto lazy = ranker.rankLazy(static_cast<std::size_t>(choose));
  const double lazy_ms = millisecondsSince(start);
  bool same = naive.size() == lazy.size();
  for (std::size_t i = 0; same && i < naive.size(); ++i) same = naive[i].index == lazy[i].index;

  // CCIR: every keyframe kept with its footprint; teammate robot_c already holds the first
  // quarter.
  core::routing::CcirBroker broker("robot_a", {"robot_b", "robot_c"},
                                   core::routing::BrokerParams{});
  const info::OccupancyMap empty(params);
  double footprint_ms = 0;
  for (int i = 0; i < held + candidates; ++i) {
    pcl::PointCloud<pcl::PointXYZ> sensor;
    const core::Pose3 to_sensor = frames[i].pose.inverse();
    for (const auto& p : frames[i].world_points) {
      const Eigen::Vector3d q = to_sensor * p.getVector3fMap().cast<double>();
      sensor.push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
    }
    start = std::chrono::steady_clock::now();
    auto footprint = core::routing::CcirBroker::footprint(empty, sensor, frames[i].pose);
    footprint_ms += millisecondsSince(start);
    broker.addKeyframe(i, i, frames[i].pose, 60000, std::move(footprint));
    broker.setCorrespondences("robot_b", i, i % 7);
  }
  const core::routing::LinkState link{true, 150000.0, 300000.0, 0};
  broker.setLink("robot_c", link);
  const auto first = broker.makeOffer("robot_c", 0.0);
  core::routing::Request take{"robot_c", "robot_a", first->sequence, {}};
  for (int round = 0; round < (held + candidates) / 4 && first; ++round) {
    broker.setLink("robot_c", link);
    const auto offer = broker.makeOffer("robot_c", 0.0);
    if (!offer) break;
    take.offer_sequence = offer->sequence;
    take.ids = {offer->scans.front().id};
    broker.onRequest(take, 0.0);
  }
  double offer_ms = 0;
  std::size_t offered = 0;
  for (const char* peer : {"robot_b", "robot_c"}) {
    broker.setLink(peer, link);
    start = std::chrono::steady_clock::now();
    const auto offer = broker.makeOffer(peer, 1.0);
    offer_ms += millisecondsSince(start);
    offered += offer ? offer->scans.size() : 0;
  }
  core::routing::CcirBroker requester("robot_b", {"robot_a"}, core::routing::BrokerParams{});
  requester.setLink("robot_a", link);
  requester.setTeamTransform("robot_a", core::Pose3::Identity());
  core::routing::Offer offer{"robot_a", "robot_b", 1, {}};
  for (int i = 0; i < 10; ++i) {
    core::routing::OfferEntry entry;
    entry.id = i;
    entry.pose = frames[held + i].pose;
    entry.correspondences = i;
    entry.size_bytes = 60000;
    offer.scans.push_back(entry);
  }
  requester.onOffer(offer);
  start = std::chrono::steady_clock::now();
  const auto requests = requester.chooseRequests(
      [&](const core::Pose3& sensor_pose) { return map.simulatedCsqmi(sensor_pose); }, 0.0);
  const double requests_ms = millisecondsSince(start);

  const double n = candidates;
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
      "\"requested\": %zu}\n}\n",
      params.resolution_m, held ? double(points) / held : 0.0, held ? insert_ms / held : 0.0,
      scan_mi_ms / n,
      frames[held].world_points.size() / static_cast<std::size_t>(params.scan_beam_step),
      simulated_mi_ms / n,
      static_cast<int>(16 * std::ceil(360 / params.simulated_azimuth_step_deg)), gains_ms / n,
      voxels / n, choose, candidates, naive_ms, lazy_ms, naive_ms / lazy_ms, naive_evaluations,
      ranker.evaluations(), same ? "true" : "false", held + candidates,
      footprint_ms / (held + candidates), offer_ms / 2, offered, requests_ms, offer.scans.size(),
      requests.empty() ? std::size_t{0} : requests.front().ids.size());
  return same ? 0 : 1;
}
