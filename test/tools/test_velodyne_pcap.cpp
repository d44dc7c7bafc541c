// Real Velodyne packet captures (CCIR_DATA_DIR/lidar) decoded through MRPT, turned into the
// driver's PointCloud2 layout and run through the Preprocessor's core; and pcap_to_bag.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>

#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/core/velodyne/velodyne_pcap_reader.h"
#include "ccir_mapping/ros/conversions.h"
#include "command_run.h"

namespace ccir_mapping {
namespace {

namespace fs = std::filesystem;
using core::velodyne::VelodynePcapReader;

fs::path capture(const std::string& name) {
  const char* dir = std::getenv("CCIR_DATA_DIR");
  return fs::path(dir ? dir : CCIR_DEFAULT_DATA_DIR) / "lidar" / name;
}

#define SKIP_WITHOUT(file)                                                            \
  if (!fs::exists(capture(file))) {                                                   \
    GTEST_SKIP() << "SKIPPED: " << capture(file) << " not found (set CCIR_DATA_DIR)"; \
  }

std::vector<core::LidarScan> readAll(const std::string& name, const std::string& model) {
  VelodynePcapReader reader(capture(name).string(), model, core::fromSeconds(100.0));
  std::vector<core::LidarScan> scans;
  while (auto scan = reader.next()) scans.push_back(std::move(*scan));
  return scans;
}

class Vlp16Captures : public ::testing::TestWithParam<std::string> {};

TEST_P(Vlp16Captures, DecodeIntoRingsByElevationAndThroughThePreprocessor) {
  SKIP_WITHOUT(GetParam());
  // velodyne_vlp16.pcap's factory byte says HDL-32E: the model given wins.
  const auto scans = readAll(GetParam(), "VLP16");
  ASSERT_GE(scans.size(), 1U);
  const core::LidarScan& scan = scans.front();
  EXPECT_EQ(scan.stamp, core::fromSeconds(100.0));
  EXPECT_EQ(scan.rings, 16);
  ASSERT_GT(scan.points.size(), 2000U);
  std::set<int> rings;
  for (const auto& p : scan.points) {
    const double elevation = std::atan2(p.z, std::hypot(p.x, p.y)) * 180.0 / M_PI;
    ASSERT_NEAR(elevation, -15.0 + 2.0 * p.ring, 0.5) << "ring " << p.ring;
    ASSERT_GE(p.time, 0.0F);
    ASSERT_LT(p.time, 0.2F);
    rings.insert(p.ring);
  }
  EXPECT_EQ(rings.size(), 16U);

  sensor_msgs::PointCloud2 cloud;
  conversions::toPointCloud2(scan, "velodyne", &cloud);
  conversions::CloudFields fields;
  ASSERT_FALSE(conversions::checkCloud(cloud, &fields));
  EXPECT_TRUE(fields.ring && fields.time && fields.intensity);
  pcl::PointCloud<pcl::PointXYZI> points;
  conversions::toPcl(cloud, &points);
  core::preprocess::PreprocessStats stats;
  const auto keyframe = core::preprocess::ScanPreprocessor(core::preprocess::PreprocessorParams{})
                            .process(points, Eigen::Vector3f::UnitZ(), &stats);
  EXPECT_GT(keyframe->size(), 500U);
  EXPECT_EQ(stats.points_in, scan.points.size());
}

INSTANTIATE_TEST_SUITE_P(Velodyne, Vlp16Captures,
                         ::testing::Values("velodyne_vlp16.pcap", "velodyne_example.pcap"));

TEST(VelodynePcapReader, Hdl32RotationsFollowThePacketClock) {
  SKIP_WITHOUT("hdl32_example.pcap");
  const auto scans = readAll("hdl32_example.pcap", "HDL32");
  ASSERT_GE(scans.size(), 5U);
  EXPECT_EQ(scans.front().rings, 32);
  // About 10 rotations per second (the first one is partial: the capture starts mid-turn).
  for (size_t i = 2; i < scans.size(); ++i) {
    EXPECT_NEAR(core::toSeconds(scans[i].stamp - scans[i - 1].stamp), 0.085, 0.03);
  }
}

TEST(VelodynePcapReader, MissingFilesAndUnknownModelsAreClearErrors) {
  EXPECT_THROW(VelodynePcapReader("/nonexistent.pcap", "VLP16", 0), std::runtime_error);
  try {
    VelodynePcapReader("/nonexistent.pcap", "VLP16", 0);
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent.pcap"), std::string::npos);
  }
  EXPECT_THROW(VelodynePcapReader("/nonexistent.pcap", "VLP99", 0), std::invalid_argument);
}

/// The global header and the first `records` records of velodyne_vlp16.pcap, then half of the
/// next one, as a file.
fs::path cutCapture(int records) {
  std::ifstream in(capture("velodyne_vlp16.pcap"), std::ios::binary);
  std::vector<char> bytes(24);
  in.read(bytes.data(), 24);
  for (int record = 0; record <= records; ++record) {
    std::array<char, 16> header;
    in.read(header.data(), 16);
    const std::uint32_t length = std::uint8_t(header[8]) | std::uint8_t(header[9]) << 8 |
                                 std::uint8_t(header[10]) << 16 | std::uint32_t(header[11]) << 24;
    std::vector<char> body(length);
    in.read(body.data(), length);
    bytes.insert(bytes.end(), header.begin(), header.end());
    bytes.insert(bytes.end(), body.begin(),
                 body.begin() + (record < records ? length : length / 2));
  }
  const fs::path cut =
      fs::temp_directory_path() / ("ccir_cut_" + std::to_string(records) + ".pcap");
  std::ofstream(cut, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  return cut;
}

TEST(VelodynePcapReader, CutCapturesGiveTheirRotationsOrAClearErrorNeverHang) {
  SKIP_WITHOUT("velodyne_vlp16.pcap");
  // Cut after 90 of its 100 records: MRPT ends there, after the whole rotations.
  const fs::path late = cutCapture(90);
  std::size_t rotations = 0;
  for (VelodynePcapReader reader(late.string(), "VLP16", 0); reader.next();) ++rotations;
  EXPECT_GE(rotations, 1U);
  // Regression (fuzz_pcap_reader): cut in its first record, MRPT's reader retried it forever.
  const fs::path early = cutCapture(0);
  VelodynePcapReader reader(early.string(), "VLP16", 0);
  try {
    reader.next();
    ADD_FAILURE() << "a capture cut in its first record read as complete";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(early.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  fs::remove(late);
  fs::remove(early);
  // Regression (fuzz_pcap_reader): libpcap crashed on a header with a nonsense link type; such
  // files, and files too short for a header, never reach it.
  const fs::path bad = fs::temp_directory_path() / "ccir_bad_link_type.pcap";
  const std::uint8_t header[24] = {0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0, 0,    0,    0,    0,
                                   0,    0,    0,    0,    0, 0, 1, 0, 0x00, 0x00, 0xb1, 0xb4};
  std::ofstream(bad, std::ios::binary).write(reinterpret_cast<const char*>(header), 24);
  try {
    VelodynePcapReader reader(bad.string(), "VLP16", 0);
    ADD_FAILURE() << "a capture of link type 0xb4b10000 was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not Ethernet"), std::string::npos) << e.what();
  }
  std::ofstream(bad, std::ios::binary | std::ios::trunc).write("\xd4\xc3", 2);
  EXPECT_THROW(VelodynePcapReader(bad.string(), "VLP16", 0), std::runtime_error);
  fs::remove(bad);
}

int run(const std::string& arguments, std::string* output) {
  const test::CommandRun done = test::runCommand(std::string(PCAP_TO_BAG) + " " + arguments);
  output->append(done.output);
  return done.exit_code;
}

TEST(PcapToBag, WritesTheDriversCloudsAndRefusesBadArguments) {
  SKIP_WITHOUT("velodyne_example.pcap");
  const fs::path bag_file =
      fs::temp_directory_path() / ("pcap_to_bag_" + std::to_string(::getpid()) + ".bag");
  std::string output;
  ASSERT_EQ(run("--pcap " + capture("velodyne_example.pcap").string() + " --out " +
                    bag_file.string() + " --frame robot_a/velodyne",
                &output),
            0)
      << output;
  {
    rosbag::Bag bag(bag_file.string());
    int clouds = 0;
    for (const auto& m : rosbag::View(bag, rosbag::TopicQuery("/velodyne_points"))) {
      const auto cloud = m.instantiate<sensor_msgs::PointCloud2>();
      ASSERT_TRUE(cloud);
      EXPECT_EQ(cloud->header.frame_id, "robot_a/velodyne");
      EXPECT_EQ(cloud->point_step, 22U);
      EXPECT_GT(cloud->width, 2000U);
      ++clouds;
    }
    EXPECT_GE(clouds, 1);
  }
  fs::remove(bag_file);

  output.clear();
  EXPECT_EQ(run("--out x.bag", &output), 2) << output;
  output.clear();
  EXPECT_EQ(run("--pcap a.pcap --out x.bag --model VLP99", &output), 2);
  EXPECT_NE(output.find("--model"), std::string::npos) << output;
  output.clear();
  EXPECT_EQ(run("--pcap /nonexistent.pcap --out x.bag", &output), 1);
  EXPECT_NE(output.find("/nonexistent.pcap"), std::string::npos) << output;
}

}  // namespace
}  // namespace ccir_mapping
