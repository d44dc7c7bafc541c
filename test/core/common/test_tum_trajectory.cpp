#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ccir_mapping/core/common/tum_trajectory.h"

namespace ccir_mapping::core {
namespace {

class TumTrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("tum_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string file(const std::string& text) const {
    const std::string path = (dir_ / "t.tum").string();
    std::ofstream(path) << text;
    return path;
  }
  std::filesystem::path dir_;
};

TEST_F(TumTrajectoryTest, RoundTripKeepsEpochStampsToTheNanosecond) {
  TumTrajectory written;
  for (int i = 0; i < 3; ++i) {
    Pose3 pose = Pose3::Identity();
    pose.translation() = Eigen::Vector3d(1.5 * i, -2.25, 0.125 * i);
    pose.linear() =
        Eigen::AngleAxisd(0.3 * i + 0.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    written.stamps.push_back(1733400000123456789 + i);  // a double holds only ~1e-7 s of it
    written.poses.push_back(pose);
  }
  written.stamps[0] = 0;
  const std::string path = (dir_ / "out.tum").string();
  TumTrajectoryWriter::write(path, "robot_a in robot_a/map\nsecond line", written);

  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "# robot_a in robot_a/map");
  const TumTrajectory read = readTumTrajectory(path);
  ASSERT_EQ(read.stamps, written.stamps);
  ASSERT_EQ(read.poses.size(), written.poses.size());
  for (std::size_t i = 0; i < read.poses.size(); ++i) {
    EXPECT_TRUE(read.poses[i].isApprox(written.poses[i], 1e-6)) << i;
  }
}

TEST_F(TumTrajectoryTest, ReadsWhatOtherToolsWrite) {
  // Fewer decimals, more than nine (rounded), no fraction, blank lines and comments.
  const auto read = readTumTrajectory(
      file("# header\n\n1.5 1 2 3 0 0 0 1\n2.1234567894 0 0 0 0 0 0.7071068 0.7071068\n"
           "  3 0 0 0 0 0 0 1\n4.0000000005 0 0 0 0 0 0 1\n"));
  EXPECT_EQ(read.stamps, (std::vector<Stamp>{1500000000, 2123456789, 3000000000, 4000000001}));
  EXPECT_TRUE(read.poses[0].translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_NEAR(Eigen::AngleAxisd(read.poses[1].linear()).angle(), M_PI / 2, 1e-6);
}

TEST_F(TumTrajectoryTest, MalformedLinesAreNamed) {
  for (const char* bad : {"1.0 0 0 0 0 0 0\n",       // seven numbers
                          "1.0 0 0 0 0 0 0 1 9\n",   // nine
                          "-1.0 0 0 0 0 0 0 1\n",    // negative stamp
                          "1e9 0 0 0 0 0 0 1\n",     // not a plain stamp
                          "1.0 nan 0 0 0 0 0 1\n",   // not finite
                          "1.0 0 0 0 0 0 0 2\n",     // not a unit quaternion
                          "1.0 0 0 0 x 0 0 1\n"}) {  // not a number
    try {
      readTumTrajectory(file(std::string("# ok\n2.0 0 0 0 0 0 0 1\n") + bad));
      ADD_FAILURE() << "accepted " << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("t.tum:3:"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(readTumTrajectory((dir_ / "missing.tum").string()), std::runtime_error);
}

TEST_F(TumTrajectoryTest, WriterRefusesWhatItCannotWrite) {
  EXPECT_THROW(TumTrajectoryWriter((dir_ / "no_such_dir" / "t.tum").string(), ""),
               std::runtime_error);
  TumTrajectoryWriter writer((dir_ / "t.tum").string(), "");
  EXPECT_THROW(writer.add(-1, Pose3::Identity()), std::invalid_argument);
  TumTrajectory uneven;
  uneven.stamps = {1, 2};
  uneven.poses = {Pose3::Identity()};
  EXPECT_THROW(TumTrajectoryWriter::write((dir_ / "u.tum").string(), "", uneven),
               std::invalid_argument);
}

}  // namespace
}  // namespace ccir_mapping::core
