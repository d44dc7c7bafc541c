// What simulate_team writes: bags with the driver's cloud layout and the expected topics and
// rates, ground-truth files, mission.yaml, identical output for a seed; and the command line's
// help and exit codes. No master needed.
#include <gtest/gtest.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>

#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/mission_files.h"
#include "command_run.h"

namespace ccir_mapping::simulation_io {
namespace {

namespace fs = std::filesystem;
namespace sim = core::simulation;

sim::MissionParams shortMission() {
  sim::MissionParams params;
  params.robots = 2;
  params.duration_s = 2.0;
  params.start_interval_s = 0.5;
  params.lidar.lidar_columns = 450;
  return params;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("ccir_sim_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<RobotRecording> writeAll(const sim::Mission& mission, const fs::path& dir) {
  std::vector<RobotRecording> recordings;
  for (size_t i = 0; i < mission.robots().size(); ++i) {
    recordings.push_back(writeRobotRecording(mission, static_cast<int>(i), dir.string(), {}));
  }
  writeMissionFile(mission, recordings, dir.string(), "test");
  return recordings;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class SimulatedMissionFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mission_ = new sim::Mission(shortMission());
    dir_ = new fs::path(freshDir("files"));
    recordings_ = new std::vector<RobotRecording>(writeAll(*mission_, *dir_));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete recordings_;
    delete dir_;
    delete mission_;
  }
  static sim::Mission* mission_;
  static fs::path* dir_;
  static std::vector<RobotRecording>* recordings_;
};
sim::Mission* SimulatedMissionFiles::mission_ = nullptr;
fs::path* SimulatedMissionFiles::dir_ = nullptr;
std::vector<RobotRecording>* SimulatedMissionFiles::recordings_ = nullptr;

TEST_F(SimulatedMissionFiles, BagHasTheTopicsAndRates) {
  rosbag::Bag bag((*dir_ / "robot_a.bag").string());
  rosbag::View view(bag);
  std::map<std::string, int> counts;
  std::map<std::string, bool> latched;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    latched[c->topic] = c->header->count("latching") && c->header->at("latching") == "1";
  }
  for (const rosbag::MessageInstance& m : view) ++counts[m.getTopic()];
  // 2 s at 10 Hz scans and 50 Hz odometry (both ends included).
  EXPECT_EQ(counts["/velodyne_points"], 20);
  EXPECT_EQ(counts["/odom"], 101);
  EXPECT_EQ(counts["/ground_truth"], 101);
  EXPECT_EQ(counts["/tf"], 101);
  EXPECT_EQ(counts["/tf_static"], 1);
  EXPECT_EQ(counts["/sim/world"], 1);
  EXPECT_EQ(counts.size(), 6U);
  EXPECT_TRUE(latched["/tf_static"]);
  EXPECT_TRUE(latched["/sim/world"]);
  EXPECT_FALSE(latched["/odom"]);
  EXPECT_EQ((*recordings_)[0].scans, 20U);
  EXPECT_EQ((*recordings_)[1].scans, 15U);  // robot_b starts 0.5 s later
}

TEST_F(SimulatedMissionFiles, CloudsHaveTheVelodyneDriverLayout) {
  rosbag::Bag bag((*dir_ / "robot_a.bag").string());
  rosbag::View view(bag, rosbag::TopicQuery("/velodyne_points"));
  ros::Time previous_stamp;
  int scans = 0;
  for (const rosbag::MessageInstance& m : view) {
    const auto cloud = m.instantiate<sensor_msgs::PointCloud2>();
    ASSERT_TRUE(cloud);
    EXPECT_EQ(cloud->header.frame_id, "robot_a/velodyne");
    conversions::CloudFields fields;
    const auto error = conversions::checkCloud(*cloud, &fields);
    ASSERT_FALSE(error) << *error;
    EXPECT_TRUE(fields.intensity && fields.ring && fields.time);
    ASSERT_EQ(cloud->fields.size(), 6U);
    const std::array<std::pair<const char*, std::uint32_t>, 6> layout{
        {{"x", 0}, {"y", 4}, {"z", 8}, {"intensity", 12}, {"ring", 16}, {"time", 18}}};
    for (size_t i = 0; i < layout.size(); ++i) {
      EXPECT_EQ(cloud->fields[i].name, layout[i].first);
      EXPECT_EQ(cloud->fields[i].offset, layout[i].second);
    }
    EXPECT_EQ(cloud->fields[4].datatype, sensor_msgs::PointField::UINT16);
    EXPECT_EQ(cloud->point_step, 22U);
    EXPECT_EQ(cloud->height, 1U);
    EXPECT_EQ(cloud->width, 16U * 450U);  // a closed mine returns every beam
    EXPECT_TRUE(cloud->is_dense);
    // Published when the sweep ends; sweeps follow each other.
    EXPECT_NEAR((m.getTime() - cloud->header.stamp).toSec(), 0.1, 1e-9);
    if (scans++ > 0) {
      EXPECT_NEAR((cloud->header.stamp - previous_stamp).toSec(), 0.1, 1e-9);
    }
    previous_stamp = cloud->header.stamp;
  }
  EXPECT_EQ(scans, 20);
}

TEST_F(SimulatedMissionFiles, OdometryTfAndGroundTruthUseTheRobotsFrames) {
  rosbag::Bag bag((*dir_ / "robot_b.bag").string());
  rosbag::View view(bag);
  int odometry = 0;
  for (const rosbag::MessageInstance& m : view) {
    if (m.getTopic() == "/odom" || m.getTopic() == "/ground_truth") {
      const auto odom = m.instantiate<nav_msgs::Odometry>();
      ASSERT_TRUE(odom);
      EXPECT_EQ(odom->header.frame_id, "robot_b/odom");
      EXPECT_EQ(odom->child_frame_id, "robot_b/base_link");
      EXPECT_TRUE(conversions::toPose(odom->pose.pose));
      odometry += m.getTopic() == "/odom";
    } else if (m.getTopic() == "/tf_static") {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_EQ(tf->transforms.size(), 1U);
      EXPECT_EQ(tf->transforms[0].header.frame_id, "robot_b/base_link");
      EXPECT_EQ(tf->transforms[0].child_frame_id, "robot_b/velodyne");
      EXPECT_DOUBLE_EQ(tf->transforms[0].transform.translation.z, 0.5);
    } else if (m.getTopic() == "/tf") {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_EQ(tf->transforms.size(), 1U);
      EXPECT_EQ(tf->transforms[0].child_frame_id, "robot_b/base_link");
    }
  }
  EXPECT_EQ(odometry, 76);  // 1.5 s at 50 Hz
}

TEST_F(SimulatedMissionFiles, GroundTruthFileMatchesTheBag) {
  std::ifstream in(*dir_ / "robot_a_gt.txt");
  std::string line;
  std::vector<std::array<double, 8>> rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::array<double, 8> row;
    for (double& v : row) ASSERT_TRUE(fields >> v) << line;
    rows.push_back(row);
  }
  ASSERT_EQ(rows.size(), 101U);
  EXPECT_DOUBLE_EQ(rows.front()[0], 100.0);  // start_time_s
  EXPECT_DOUBLE_EQ(rows.front()[1], 0.0);    // starts at its own origin
  EXPECT_DOUBLE_EQ(rows.front()[7], 1.0);
  EXPECT_NEAR(std::hypot(rows.back()[1], rows.back()[2]), 2.0, 0.05);  // 1 m/s for 2 s
}

TEST_F(SimulatedMissionFiles, MissionFileHoldsParametersAndTrueStartPoses) {
  const YAML::Node mission = YAML::LoadFile((*dir_ / "mission.yaml").string());
  EXPECT_EQ(mission["format"].as<std::string>(), "ccir_mapping/mission 1");
  EXPECT_EQ(mission["world"]["kind"].as<std::string>(), "mine");
  EXPECT_EQ(mission["parameters"]["seed"].as<int>(), 7);
  EXPECT_DOUBLE_EQ(mission["parameters"]["lidar_range_noise_m"].as<double>(), 0.03);
  ASSERT_EQ(mission["robots"].size(), 2U);
  for (size_t i = 0; i < 2; ++i) {
    const YAML::Node robot = mission["robots"][i];
    const auto& plan = mission_->robots()[i];
    EXPECT_EQ(robot["name"].as<std::string>(), plan.name);
    EXPECT_EQ(robot["bag"].as<std::string>(), plan.name + ".bag");
    const YAML::Node pose = robot["initial_pose_in_world"];
    EXPECT_NEAR(pose["x"].as<double>(), plan.world_from_odom.translation().x(), 1e-9);
    EXPECT_NEAR(pose["y"].as<double>(), plan.world_from_odom.translation().y(), 1e-9);
    EXPECT_NEAR(pose["qw"].as<double>() * pose["qw"].as<double>() +
                    pose["qz"].as<double>() * pose["qz"].as<double>(),
                1.0, 1e-9);
  }
}

TEST_F(SimulatedMissionFiles, SameSeedWritesIdenticalBags) {
  const fs::path again = freshDir("again");
  writeAll(sim::Mission(shortMission()), again);
  for (const char* file : {"robot_a.bag", "robot_b.bag", "robot_a_gt.txt"}) {
    EXPECT_TRUE(readFile(*dir_ / file) == readFile(again / file)) << file << " differs";
  }
  fs::remove_all(again);
}

TEST(SimulatedScanConversion, OrganisedScansKeepRingRows) {
  core::LidarScan scan;
  scan.organized = true;
  scan.columns = 4;
  scan.points.assign(64, core::LidarPoint{1.0F, 2.0F, 3.0F, 4.0F, 5, 0.25F});
  sensor_msgs::PointCloud2 cloud;
  conversions::toPointCloud2(scan, "robot_a/velodyne", &cloud);
  EXPECT_EQ(cloud.height, 16U);
  EXPECT_EQ(cloud.width, 4U);
  EXPECT_FALSE(cloud.is_dense);
  EXPECT_FALSE(conversions::checkCloud(cloud, nullptr));
  float time = 0.0F;
  std::uint16_t ring = 0;
  std::memcpy(&ring, &cloud.data[22 * 3 + 16], 2);
  std::memcpy(&time, &cloud.data[22 * 3 + 18], 4);
  EXPECT_EQ(ring, 5);
  EXPECT_EQ(time, 0.25F);
}

// --- the command line ---------------------------------------------------------------------------

using test::CommandRun;

CommandRun simulateTeam(const std::string& arguments) {
  return test::runCommand(std::string(SIMULATE_TEAM) + " " + arguments);
}

TEST(SimulateTeamCommand, HelpDocumentsEveryParameterWithUnitAndDefault) {
  CommandRun help = simulateTeam("--help");
  ASSERT_EQ(help.exit_code, 0) << help.output;
  // Descriptions wrap: compare with single spaces.
  std::string flat;
  for (char c : help.output) {
    if (!std::isspace(static_cast<unsigned char>(c))) {
      flat += c;
    } else if (!flat.empty() && flat.back() != ' ') {
      flat += ' ';
    }
  }
  help.output = flat;
  struct Names {
    std::vector<std::string> flags;
    void add(const char* name) {
      std::string flag = name;
      std::replace(flag.begin(), flag.end(), '_', '-');
      flags.push_back("--" + flag);
    }
    void number(const char* n, double, const char*, double, double, const char*) { add(n); }
    void integer(const char* n, int, const char*, int, int, const char*) { add(n); }
    void flag(const char* n, bool, const char*) { add(n); }
    void choice(const char* n, const std::string&, const std::vector<std::string>&, const char*) {
      add(n);
    }
  } names;
  const sim::MissionParams defaults;
  sim::MissionParams::fields(defaults, names);
  EXPECT_GT(names.flags.size(), 40U);
  for (const auto& flag : names.flags) {
    EXPECT_NE(help.output.find(flag + " "), std::string::npos) << flag << " is not documented";
  }
  EXPECT_NE(help.output.find("--mine-pillar-size-m m (=10)"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("[m]"), std::string::npos);
  EXPECT_NE(help.output.find("mine | building | cave | cluttered"), std::string::npos);
}

TEST(SimulateTeamCommand, BadValuesExitWithCode2AndNameTheFlag) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--robots 0", "--robots: robots = 0 is out of range"},
      {"--world moon", "--world: world = 'moon' is not allowed"},
      {"--duration -3", "--duration-s: duration_s = -3"},
      {"--robots two", "robots"},
      {"--no-such-flag 1", "no-such-flag"},
      {"--aerial-robots 5", "--aerial-robots"},
      {"--compression zip", "--compression"},
  };
  for (const auto& [arguments, expected] : cases) {
    const CommandRun run = simulateTeam(arguments + " --out /nonexistent/never_written");
    EXPECT_EQ(run.exit_code, 2) << arguments << "\n" << run.output;
    EXPECT_NE(run.output.find(expected), std::string::npos) << arguments << "\n" << run.output;
  }
}

TEST(SimulateTeamCommand, OutputDoesNotDependOnTheThreadCount) {
  const fs::path one = freshDir("one_thread");
  const fs::path two = freshDir("two_threads");
  const std::string mission = "--robots 3 --duration 1 --lidar-columns 360 --start-interval-s 0.2";
  ASSERT_EQ(simulateTeam(mission + " --threads 1 --out " + one.string()).exit_code, 0);
  ASSERT_EQ(simulateTeam(mission + " --threads 2 --out " + two.string()).exit_code, 0);
  for (const char* file : {"robot_a.bag", "robot_b.bag", "robot_c.bag", "robot_c_gt.txt"}) {
    EXPECT_TRUE(readFile(one / file) == readFile(two / file)) << file << " differs";
  }
  fs::remove_all(one);
  fs::remove_all(two);
}

TEST(SimulateTeamCommand, WritesAMissionAndReportsUnwritableOutput) {
  const fs::path dir = freshDir("command");
  const CommandRun run = simulateTeam(
      "--world cave --robots 2 --aerial-robots 1 --duration 1 "
      "--lidar-columns 360 --seed 3 --out " +
      dir.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* file :
       {"mission.yaml", "robot_a.bag", "robot_b.bag", "robot_a_gt.txt", "robot_b_gt.txt"}) {
    EXPECT_TRUE(fs::exists(dir / file)) << file;
  }
  EXPECT_EQ(YAML::LoadFile((dir / "mission.yaml").string())["robots"][1]["kind"].as<std::string>(),
            "aerial");
  fs::remove_all(dir);

  const CommandRun blocked = simulateTeam("--duration 1 --out /proc/not_a_dir");
  EXPECT_EQ(blocked.exit_code, 1) << blocked.output;
  EXPECT_NE(blocked.output.find("/proc/not_a_dir"), std::string::npos) << blocked.output;
}

}  // namespace
}  // namespace ccir_mapping::simulation_io
