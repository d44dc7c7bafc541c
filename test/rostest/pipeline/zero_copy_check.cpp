// Checks the reports of two CloudProbes: the one in the source's manager must receive the very
// object that was published; the one in another process must receive a copy.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include "wait_for.h"

namespace {

std::vector<std::string> collect(const std::string& topic, std::size_t n) {
  ros::NodeHandle nh;
  std::vector<std::string> reports;
  auto sub = nh.subscribe<std_msgs::String>(
      topic, 100, [&](const std_msgs::String::ConstPtr& msg) { reports.push_back(msg->data); });
  EXPECT_TRUE(ccir_mapping::testing::waitFor([&] { return reports.size() >= n; }, 30.0))
      << "only " << reports.size() << " reports on " << topic;
  return reports;
}

TEST(ZeroCopy, SameManagerReceivesThePublishedObject) {
  const auto reports = collect("report_same", 20);
  for (const auto& report : reports) EXPECT_EQ(report, "same_process same_address");
}

TEST(ZeroCopy, AnotherProcessReceivesACopy) {
  const auto reports = collect("report_other", 20);
  for (const auto& report : reports) EXPECT_EQ(report, "other_process copy");
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "zero_copy_check");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
