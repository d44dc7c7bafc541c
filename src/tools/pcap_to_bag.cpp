// pcap_to_bag: Velodyne packet capture (pcap) -> rosbag with sensor_msgs/PointCloud2 on
// velodyne_points in the Velodyne ROS driver's layout (x y z intensity ring time), for users
// without the driver. Decoding is MRPT's. Exit codes: 0 done, 1 cannot read or write, 2 bad
// arguments.
#include <cstdio>
#include <iostream>

#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <boost/program_options.hpp>

#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "ccir_mapping/ros/conversions.h"

namespace po = boost::program_options;

int main(int argc, char** argv) {
  std::string pcap;
  std::string out;
  std::string model = "VLP16";
  std::string frame = "velodyne";
  std::string topic = "/velodyne_points";
  double start_time_s = 100.0;
  double min_range_m = 0.4;
  po::options_description options(
      "Usage: pcap_to_bag --pcap FILE --out BAG [--model VLP16] [--frame velodyne]\n"
      "Decodes every rotation of a Velodyne pcap into a PointCloud2 (x y z intensity ring time,\n"
      "no-returns dropped). Stamps follow the sensor's packet clock from --start-time-s. The\n"
      "model is never read from the packets (their factory byte can be wrong).\n\nOptions",
      100);
  options.add_options()("help,h", "print this help and exit")("pcap", po::value<std::string>(&pcap),
                                                              "Velodyne packet capture to read")(
      "out", po::value<std::string>(&out), "bag to write")(
      "model", po::value<std::string>(&model)->default_value(model),
      "sensor model; allowed VLP16 | HDL32 | HDL64")(
      "frame", po::value<std::string>(&frame)->default_value(frame), "frame_id of the clouds")(
      "topic", po::value<std::string>(&topic)->default_value(topic), "topic in the bag")(
      "start-time-s", po::value<double>(&start_time_s)->default_value(start_time_s),
      "stamp of the first rotation [s]; allowed > 0")(
      "min-range-m", po::value<double>(&min_range_m)->default_value(min_range_m),
      "nearer returns are dropped [m]; allowed >= 0");
  po::variables_map arguments;
  try {
    po::store(po::parse_command_line(argc, argv, options), arguments);
    po::notify(arguments);
  } catch (const po::error& e) {
    std::cerr << "pcap_to_bag: " << e.what() << " (see pcap_to_bag --help)\n";
    return 2;
  }
  if (arguments.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  if (pcap.empty() || out.empty()) {
    std::cerr << "pcap_to_bag: --pcap and --out are required (see pcap_to_bag --help)\n";
    return 2;
  }
  if (!(start_time_s > 0.0) || !(min_range_m >= 0.0) || frame.empty() || topic.empty()) {
    std::cerr << "pcap_to_bag: --start-time-s must be > 0, --min-range-m >= 0, --frame and "
                 "--topic non-empty\n";
    return 2;
  }

  try {
    ccir_mapping::core::velodyne::VelodynePcapReader reader(
        pcap, model, ccir_mapping::core::fromSeconds(start_time_s), min_range_m);
    rosbag::Bag bag(out, rosbag::bagmode::Write);
    std::size_t scans = 0;
    std::size_t points = 0;
    sensor_msgs::PointCloud2 cloud;
    while (const auto scan = reader.next()) {
      ccir_mapping::conversions::toPointCloud2(*scan, frame, &cloud);
      if (cloud.width == 0) continue;  // a rotation without a single return
      bag.write(topic, cloud.header.stamp, cloud);
      ++scans;
      points += cloud.width;
    }
    bag.close();
    std::printf("pcap_to_bag: %zu rotation(s), %zu points (%d rings) from %s -> %s on %s\n", scans,
                points, reader.rings(), pcap.c_str(), out.c_str(), topic.c_str());
  } catch (const std::invalid_argument& e) {
    std::cerr << "pcap_to_bag: --model: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "pcap_to_bag: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
