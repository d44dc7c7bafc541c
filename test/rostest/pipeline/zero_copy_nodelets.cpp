// Test-only nodelets proving zero-copy transport: CloudSource publishes clouds that carry their
// own publishing process id and address; CloudProbe reports whether what it received is that
// very object.
#include <unistd.h>

#include <cinttypes>
#include <cstdio>

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/String.h>
#include <pluginlib/class_list_macros.hpp>

namespace ccir_mapping_test {

class CloudSource final : public nodelet::Nodelet {
 private:
  void onInit() override {
    pub_ = getNodeHandle().advertise<sensor_msgs::PointCloud2>("cloud", 10);
    timer_ =
        getNodeHandle().createSteadyTimer(ros::WallDuration(0.05), &CloudSource::publish, this);
  }

  void publish(const ros::SteadyTimerEvent&) {
    auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
    sensor_msgs::PointCloud2Modifier(*cloud).setPointCloud2FieldsByString(1, "xyz");
    sensor_msgs::PointCloud2Modifier(*cloud).resize(28800);  // one VLP-16 revolution
    char origin[64];
    std::snprintf(origin, sizeof(origin), "%d:%" PRIxPTR, static_cast<int>(getpid()),
                  reinterpret_cast<std::uintptr_t>(cloud.get()));
    cloud->header.frame_id = origin;
    cloud->header.stamp = ros::Time::now();
    pub_.publish(cloud);
  }

  ros::Publisher pub_;
  ros::SteadyTimer timer_;
};

class CloudProbe final : public nodelet::Nodelet {
 private:
  void onInit() override {
    report_pub_ = getNodeHandle().advertise<std_msgs::String>("probe_report", 10);
    sub_ = getNodeHandle().subscribe("cloud", 10, &CloudProbe::onCloud, this);
  }

  void onCloud(const sensor_msgs::PointCloud2::ConstPtr& cloud) {
    int pid = 0;
    std::uintptr_t address = 0;
    if (std::sscanf(cloud->header.frame_id.c_str(), "%d:%" SCNxPTR, &pid, &address) != 2) return;
    auto report = boost::make_shared<std_msgs::String>();
    report->data =
        std::string(pid == getpid() ? "same_process" : "other_process") + " " +
        (address == reinterpret_cast<std::uintptr_t>(cloud.get()) ? "same_address" : "copy");
    report_pub_.publish(report);
  }

  ros::Publisher report_pub_;
  ros::Subscriber sub_;
};

}  // namespace ccir_mapping_test

PLUGINLIB_EXPORT_CLASS(ccir_mapping_test::CloudSource, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(ccir_mapping_test::CloudProbe, nodelet::Nodelet)
