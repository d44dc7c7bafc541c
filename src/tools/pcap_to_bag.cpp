// pcap_to_bag: Velodyne packet capture (pcap) -> rosbag with sensor_msgs/PointCloud2 on
// velodyne_points in the Velodyne ROS driver's layout (x y z intensity ring time), for users
// without the driver. Decoding is MRPT's. Exit codes: 0 done, 1 cannot read or write, 2 bad
// arguments.
#include <cstdio>
#include <iostream>
#include <optional>
#include <stdexcept>

#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "ccir_mapping/ros/conversions.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace tools = ccir_mapping::tools;

namespace {

struct Options {
  std::string pcap;
  std::string out;
  std::string model = "VLP16";
  std::string frame = "velodyne";
  std::string topic = "/velodyne_points";
  double start_time_s = 100.0;
  double min_range_m = 0.4;
};

/// The options, or the exit code to end with (help, bad arguments).
std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: pcap_to_bag --pcap FILE --out BAG [--model VLP16] [--frame velodyne]\n"
      "Decodes every rotation of a Velodyne pcap into a PointCloud2 (x y z intensity ring time,\n"
      "no-returns dropped). Stamps follow the sensor's packet clock from --start-time-s. The\n"
      "model is never read from the packets (their factory byte can be wrong).\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")(
      "pcap", po::value<std::string>(&o->pcap), "Velodyne packet capture to read")(
      "out", po::value<std::string>(&o->out), "bag to write")(
      "model", po::value<std::string>(&o->model)->default_value(o->model),
      "sensor model; allowed VLP16 | HDL32 | HDL64")(
      "frame", po::value<std::string>(&o->frame)->default_value(o->frame),
      "frame_id of the clouds")("topic", po::value<std::string>(&o->topic)->default_value(o->topic),
                                "topic in the bag")(
      "start-time-s", po::value<double>(&o->start_time_s)->default_value(o->start_time_s),
      "stamp of the first rotation [s]; allowed > 0")(
      "min-range-m", po::value<double>(&o->min_range_m)->default_value(o->min_range_m),
      "nearer returns are dropped [m]; allowed >= 0");
  if (const auto exit_code = tools::parseCommandLine("pcap_to_bag", options, argc, argv)) {
    return exit_code;
  }
  if (o->pcap.empty() || o->out.empty()) {
    return tools::usageError("pcap_to_bag",
                             "--pcap and --out are required (see pcap_to_bag --help)");
  }
  if (!(o->start_time_s > 0.0) || !(o->min_range_m >= 0.0) || o->frame.empty() ||
      o->topic.empty()) {
    return tools::usageError("pcap_to_bag",
                             "--start-time-s must be > 0, --min-range-m >= 0, --frame and "
                             "--topic non-empty");
  }
  return std::nullopt;
}

struct Results {
  std::size_t scans = 0;
  std::size_t points = 0;
  int rings = 0;
};

/// Throws std::invalid_argument for an unknown model, std::runtime_error when the pcap cannot
/// be read or the bag written.
Results run(const Options& o) {
  ccir_mapping::core::velodyne::VelodynePcapReader reader(
      o.pcap, o.model, ccir_mapping::core::fromSeconds(o.start_time_s), o.min_range_m);
  rosbag::Bag bag(o.out, rosbag::bagmode::Write);
  Results r;
  sensor_msgs::PointCloud2 cloud;
  while (const auto scan = reader.next()) {
    ccir_mapping::conversions::toPointCloud2(*scan, o.frame, &cloud);
    if (cloud.width == 0) continue;  // a rotation without a single return
    bag.write(o.topic, cloud.header.stamp, cloud);
    ++r.scans;
    r.points += cloud.width;
  }
  bag.close();
  r.rings = reader.rings();
  return r;
}

void report(const Options& o, const Results& r) {
  std::printf("pcap_to_bag: %zu rotation(s), %zu points (%d rings) from %s -> %s on %s\n", r.scans,
              r.points, r.rings, o.pcap.c_str(), o.out.c_str(), o.topic.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const auto exit_code = parse(argc, argv, &options)) return *exit_code;
  try {
    report(options, run(options));
  } catch (const std::invalid_argument& e) {
    return tools::usageError("pcap_to_bag", std::string("--model: ") + e.what());
  } catch (const std::exception& e) {
    std::cerr << "pcap_to_bag: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
