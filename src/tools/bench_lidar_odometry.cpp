// bench_lidar_odometry: the drift of the lidar odometry (odom_source: lidar) on simulated
// missions with truth, against the simulator's wheel odometry measured in the same run, and its
// forward-backward consistency on a real Velodyne capture (no truth there: the capture played
// forwards and then backwards must bring the sensor back where it started). Prints JSON; drift
// is the end-point error per 100 m travelled and the mean error over every 10 m segment
// (KITTI's relative translation error, in %).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/preprocess/lidar_odometry.h"
#include "ccir_mapping/core/preprocess/lidar_scan_cloud.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/simulation/mission.h"
#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;
namespace sim = ccir_mapping::core::simulation;
using ccir_mapping::core::LidarScan;
using ccir_mapping::core::Pose3;
using ccir_mapping::core::Stamp;
using ccir_mapping::core::preprocess::LidarOdometry;
using ccir_mapping::core::preprocess::LidarOdometryParams;
using ccir_mapping::core::preprocess::OdometryBuffer;
using ccir_mapping::core::preprocess::toCloud;

namespace {

constexpr double kSegmentM = 10.0;

struct Options {
  std::vector<int> seeds{7, 8, 9};
  std::string world = "mine";
  double duration_s = 60.0;
  std::string pcap;
  std::string pcap_model = "HDL32";
  LidarOdometryParams odometry;
};

std::optional<int> parse(int argc, char** argv, Options* o) {
  if (const char* data = std::getenv("CCIR_DATA_DIR")) {
    o->pcap = std::string(data) + "/lidar/hdl32_example.pcap";
  }
  auto& p = o->odometry;
  po::options_description options("Usage: bench_lidar_odometry [options]");
  options.add_options()("help", "print this help")(
      "seeds", po::value<std::vector<int>>(&o->seeds)->multitoken(),
      "simulated missions (one robot each), by seed (default 7 8 9)")(
      "world", po::value<std::string>(&o->world)->default_value(o->world), "simulated world")(
      "duration-s", po::value<double>(&o->duration_s)->default_value(o->duration_s),
      "mission length, s (the robot drives at 1 m/s)")(
      "pcap", po::value<std::string>(&o->pcap),
      "real capture played forwards and backwards (default "
      "$CCIR_DATA_DIR/lidar/hdl32_example.pcap; \"\" for none)")(
      "pcap-model", po::value<std::string>(&o->pcap_model)->default_value(o->pcap_model),
      "its Velodyne model: VLP16 | HDL32 | HDL64")(
      "voxel-m", po::value<double>(&p.voxel_m)->default_value(p.voxel_m), "lidar_voxel_m")(
      "local-map-scans", po::value<int>(&p.local_map_scans)->default_value(p.local_map_scans),
      "lidar_local_map_scans")(
      "max-correspondence-m",
      po::value<double>(&p.max_correspondence_m)->default_value(p.max_correspondence_m),
      "lidar_max_correspondence_m");
  if (const auto exit_code = tools::parseCommandLine("bench_lidar_odometry", options, argc, argv)) {
    return exit_code;
  }
  if (const auto errors = p.validate(); !errors.empty()) {
    return tools::usageError("bench_lidar_odometry", errors.front());
  }
  if (o->duration_s < 1.0)
    return tools::usageError("bench_lidar_odometry", "need --duration-s >= 1");
  return std::nullopt;
}

/// Drift of `estimate` against `truth` (the same poses' stamps, any frames).
struct Drift {
  double path_m = 0.0;
  double end_error_m = 0.0;
  double segment_error_percent = 0.0;
  double perHundredMetres() const { return path_m > 0 ? 100.0 * end_error_m / path_m : 0.0; }
};

Drift drift(const std::vector<Pose3>& estimate, const std::vector<Pose3>& truth) {
  Drift d;
  std::vector<double> along{0.0};  // path length at each pose
  for (std::size_t i = 1; i < truth.size(); ++i) {
    along.push_back(along.back() + (truth[i].translation() - truth[i - 1].translation()).norm());
  }
  d.path_m = along.back();
  const auto relative = [](const std::vector<Pose3>& poses, std::size_t i,
                           std::size_t j) -> Eigen::Vector3d {
    return (poses[i].inverse() * poses[j]).translation();
  };
  d.end_error_m =
      (relative(estimate, 0, truth.size() - 1) - relative(truth, 0, truth.size() - 1)).norm();
  double sum = 0.0;
  int segments = 0;
  for (std::size_t i = 0, j = 0; i < truth.size(); ++i) {
    while (j < truth.size() && along[j] - along[i] < kSegmentM) ++j;
    if (j == truth.size()) break;
    sum += (relative(estimate, i, j) - relative(truth, i, j)).norm() / (along[j] - along[i]);
    ++segments;
  }
  d.segment_error_percent = segments ? 100.0 * sum / segments : 0.0;
  return d;
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(q * static_cast<double>(values.size() - 1))];
}

struct MissionResult {
  int seed = 0;
  std::size_t scans = 0, registered = 0;
  Drift lidar, wheel;
  std::vector<double> ms;
};

/// Feeds the robot's scans to the lidar odometry; keeps the true and the wheel odometry's
/// sensor poses at each scan's stamp.
class Recorder : public sim::RecordingSink {
 public:
  Recorder(const LidarOdometryParams& params, const Pose3& mount, MissionResult* out)
      : odometry_(params), mount_(mount), out_(out) {}
  void odometry(const sim::OdometrySample& s) override {
    truth_.add(s.stamp, s.truth);
    wheel_.add(s.stamp, s.odometry);
  }
  void scan(const LidarScan& scan, Stamp) override {
    const auto truth = truth_.at(scan.stamp, 0.05);
    const auto wheel = wheel_.at(scan.stamp, 0.05);
    if (!truth || !wheel) return;
    const auto start = std::chrono::steady_clock::now();
    const auto result = odometry_.track(scan.stamp, toCloud(scan));
    out_->ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    ++out_->scans;
    out_->registered += result.registered ? 1 : 0;
    estimate.push_back(result.pose);
    true_poses.push_back(*truth * mount_);
    wheel_poses.push_back(*wheel * mount_);
  }
  std::vector<Pose3> estimate, true_poses, wheel_poses;

 private:
  LidarOdometry odometry_;
  Pose3 mount_;
  MissionResult* out_;
  OdometryBuffer truth_, wheel_;
};

MissionResult runMission(const Options& o, int seed) {
  sim::MissionParams params;
  params.seed = seed;
  params.robots = 1;
  params.duration_s = o.duration_s;
  params.world.world = o.world;
  const sim::Mission mission(params);
  MissionResult result;
  result.seed = seed;
  Recorder recorder(o.odometry, mission.sensorMount(), &result);
  mission.record(0, recorder);
  result.lidar = drift(recorder.estimate, recorder.true_poses);
  result.wheel = drift(recorder.wheel_poses, recorder.true_poses);
  return result;
}

struct CaptureResult {
  std::size_t scans = 0, registered = 0;
  double path_m = 0.0;
  double round_trip_error_m = 0.0;
};

/// The capture forwards, then backwards (a second odometry): composed they should be identity.
CaptureResult runCapture(const Options& o) {
  CaptureResult result;
  std::vector<LidarScan> scans;
  ccir_mapping::core::velodyne::VelodynePcapReader reader(o.pcap, o.pcap_model, 0);
  while (auto scan = reader.next()) scans.push_back(std::move(*scan));
  if (scans.size() < 2) throw std::runtime_error(o.pcap + ": fewer than two rotations");
  const auto play = [&](const std::vector<LidarScan>& sequence, double* path_m) {
    LidarOdometry odometry(o.odometry);
    Stamp stamp = 0;
    Pose3 pose = Pose3::Identity();
    for (const auto& scan : sequence) {
      stamp += ccir_mapping::core::fromSeconds(0.1);
      const auto placed = odometry.track(stamp, toCloud(scan));
      ++result.scans;
      result.registered += placed.registered ? 1 : 0;
      if (path_m) *path_m += (placed.pose.translation() - pose.translation()).norm();
      pose = placed.pose;
    }
    return pose;
  };
  const Pose3 forwards = play(scans, &result.path_m);
  std::reverse(scans.begin(), scans.end());
  const Pose3 backwards = play(scans, nullptr);
  result.round_trip_error_m = (forwards * backwards).translation().norm();
  return result;
}

struct Results {
  std::vector<MissionResult> missions;
  std::optional<CaptureResult> capture;
};

Results run(const Options& o) {
  Results r;
  for (const int seed : o.seeds) r.missions.push_back(runMission(o, seed));
  if (!o.pcap.empty()) r.capture = runCapture(o);
  return r;
}

std::string driftJson(const Drift& d) {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer,
                "{\"path_m\": %.1f, \"end_error_m\": %.3f, \"m_per_100m\": %.3f, "
                "\"segment_error_percent\": %.3f}",
                d.path_m, d.end_error_m, d.perHundredMetres(), d.segment_error_percent);
  return buffer;
}

void report(const Options& o, const Results& r) {
  std::printf("{\n  \"world\": \"%s\",\n  \"duration_s\": %.0f,\n  \"voxel_m\": %.2f,\n",
              o.world.c_str(), o.duration_s, o.odometry.voxel_m);
  std::printf("  \"missions\": [\n");
  std::vector<double> all_ms;
  double lidar_sum = 0.0, wheel_sum = 0.0;
  for (std::size_t i = 0; i < r.missions.size(); ++i) {
    const auto& m = r.missions[i];
    all_ms.insert(all_ms.end(), m.ms.begin(), m.ms.end());
    lidar_sum += m.lidar.perHundredMetres();
    wheel_sum += m.wheel.perHundredMetres();
    std::printf(
        "    {\"seed\": %d, \"scans\": %zu, \"registered\": %zu,\n     \"lidar\": %s,\n"
        "     \"wheel\": %s}%s\n",
        m.seed, m.scans, m.registered, driftJson(m.lidar).c_str(), driftJson(m.wheel).c_str(),
        i + 1 < r.missions.size() ? "," : "");
  }
  const double n = static_cast<double>(std::max<std::size_t>(1, r.missions.size()));
  std::printf("  ],\n  \"mean_m_per_100m\": {\"lidar\": %.3f, \"wheel\": %.3f, \"ratio\": %.3f},\n",
              lidar_sum / n, wheel_sum / n, wheel_sum > 0 ? lidar_sum / wheel_sum : 0.0);
  std::printf("  \"ms_per_scan\": {\"p50\": %.1f, \"p95\": %.1f, \"max\": %.1f}",
              percentile(all_ms, 0.5), percentile(all_ms, 0.95), percentile(all_ms, 1.0));
  if (r.capture) {
    const auto& c = *r.capture;
    std::printf(
        ",\n  \"capture\": {\"file\": \"%s\", \"scans\": %zu, \"registered\": %zu, "
        "\"path_m\": %.2f, \"round_trip_error_m\": %.3f}",
        o.pcap.c_str(), c.scans, c.registered, c.path_m, c.round_trip_error_m);
  }
  std::printf("\n}\n");
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool<Options>("bench_lidar_odometry", argc, argv, parse, run, report);
}
