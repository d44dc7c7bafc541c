#include "ccir_mapping/ros/mission_files.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <stdexcept>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>
#include <boost/make_shared.hpp>

#include "ccir_mapping/core/common/tum_trajectory.h"
#include "ccir_mapping/ros/conversions.h"

namespace ccir_mapping::simulation_io {
namespace {

using core::LidarScan;
using core::Pose3;
using core::simulation::Mission;
using core::simulation::OdometrySample;

/// rosbag needs the whole connection header when it is given one (here: to mark a topic
/// latched, so that rosbag play latches it too).
template <class Message>
boost::shared_ptr<ros::M_string> latchedConnection() {
  auto header = boost::make_shared<ros::M_string>();
  (*header)["type"] = ros::message_traits::datatype<Message>();
  (*header)["md5sum"] = ros::message_traits::md5sum<Message>();
  (*header)["message_definition"] = ros::message_traits::definition<Message>();
  (*header)["callerid"] = "/simulate_team";
  (*header)["latching"] = "1";
  return header;
}

class BagSink : public core::simulation::RecordingSink {
 public:
  BagSink(const std::string& robot, bool planar, const std::string& prefix, rosbag::Bag* bag,
          core::TumTrajectoryWriter* ground_truth, RobotRecording* stats)
      : odom_frame_(robot + "/odom"),
        base_frame_(robot + "/base_link"),
        sensor_frame_(robot + "/velodyne"),
        points_topic_(prefix + BagTopics::kPoints),
        odom_topic_(prefix + BagTopics::kOdometry),
        truth_topic_(prefix + BagTopics::kGroundTruth),
        planar_(planar),
        bag_(bag),
        ground_truth_(ground_truth),
        stats_(stats) {}

  void odometry(const OdometrySample& sample) override {
    const ros::Time stamp = conversions::toRosTime(sample.stamp);
    nav_msgs::Odometry odom;
    odom.header.stamp = stamp;
    odom.header.frame_id = odom_frame_;
    odom.child_frame_id = base_frame_;
    odom.pose.pose = conversions::toPoseMsg(sample.odometry);
    // x y z roll pitch yaw; a ground robot's height and tilt are known (flat floor).
    const double known = 1e-6;
    odom.pose.covariance[0] = odom.pose.covariance[7] = sample.position_variance + known;
    odom.pose.covariance[14] = (planar_ ? 0.0 : sample.position_variance) + known;
    odom.pose.covariance[21] = odom.pose.covariance[28] = known;
    odom.pose.covariance[35] = sample.heading_variance + known;
    odom.twist.twist.linear.x = sample.linear_velocity.x();
    odom.twist.twist.linear.y = sample.linear_velocity.y();
    odom.twist.twist.linear.z = sample.linear_velocity.z();
    odom.twist.twist.angular.z = sample.yaw_rate;
    bag_->write(odom_topic_, stamp, odom);

    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(
        conversions::toTransformStampedMsg(stamp, odom_frame_, base_frame_, sample.odometry));
    bag_->write("/tf", stamp, tf);

    nav_msgs::Odometry truth;
    truth.header = odom.header;
    truth.child_frame_id = base_frame_;
    truth.pose.pose = conversions::toPoseMsg(sample.truth);
    bag_->write(truth_topic_, stamp, truth);

    ground_truth_->add(sample.stamp, sample.truth);
    ++stats_->odometry_messages;
  }

  void scan(const LidarScan& scan, core::Stamp published) override {
    conversions::toPointCloud2(scan, sensor_frame_, &cloud_);
    bag_->write(points_topic_, conversions::toRosTime(published), cloud_);
    ++stats_->scans;
    stats_->points += cloud_.width * cloud_.height;
  }

 private:
  std::string odom_frame_, base_frame_, sensor_frame_;
  std::string points_topic_, odom_topic_, truth_topic_;
  bool planar_;
  rosbag::Bag* bag_;
  core::TumTrajectoryWriter* ground_truth_;
  RobotRecording* stats_;
  sensor_msgs::PointCloud2 cloud_;  // reused: its buffer is the largest allocation per scan
};

/// Emits every mission parameter as `name: value`.
class YamlFields {
 public:
  explicit YamlFields(YAML::Emitter* out) : out_(out) {}
  void number(const char* name, double value, const char*, double, double, const char*) {
    *out_ << YAML::Key << name << YAML::Value << value;
  }
  void integer(const char* name, int value, const char*, int, int, const char*) {
    *out_ << YAML::Key << name << YAML::Value << value;
  }
  void flag(const char* name, bool value, const char*) {
    *out_ << YAML::Key << name << YAML::Value << value;
  }
  void choice(const char* name, const std::string& value, const std::vector<std::string>&,
              const char*) {
    *out_ << YAML::Key << name << YAML::Value << value;
  }

 private:
  YAML::Emitter* out_;
};

void emitPose(YAML::Emitter& out, const Pose3& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d& t = pose.translation();
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "x" << YAML::Value << t.x() << YAML::Key << "y" << YAML::Value << t.y();
  out << YAML::Key << "z" << YAML::Value << t.z();
  out << YAML::Key << "qx" << YAML::Value << q.x() << YAML::Key << "qy" << YAML::Value << q.y();
  out << YAML::Key << "qz" << YAML::Value << q.z() << YAML::Key << "qw" << YAML::Value << q.w();
  out << YAML::EndMap;
}

std::string robotFile(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

}  // namespace

RobotRecording writeRobotRecording(const Mission& mission, int index, const std::string& dir,
                                   const BagOptions& options) {
  const auto& robot = mission.robots().at(static_cast<size_t>(index));
  RobotRecording stats;
  stats.bag_file = robotFile(dir, robot.name + ".bag");
  stats.ground_truth_file = robotFile(dir, robot.name + "_gt.txt");

  core::TumTrajectoryWriter ground_truth(
      stats.ground_truth_file, "stamp x y z qx qy qz qw: true pose of " + robot.name +
                                   "/base_link in " + robot.name +
                                   "/odom (its start pose; see mission.yaml for the world)");

  // A bag loads its encryptor plugin when opened and unloads it when destroyed; pluginlib is not
  // thread-safe, so robots recorded in parallel take turns for both.
  static std::mutex plugin_mutex;
  std::unique_ptr<rosbag::Bag> bag_owner;
  {
    std::lock_guard<std::mutex> lock(plugin_mutex);
    bag_owner = std::make_unique<rosbag::Bag>();
    try {
      bag_owner->open(stats.bag_file, rosbag::bagmode::Write);
    } catch (const std::exception& e) {
      throw std::runtime_error("cannot write " + stats.bag_file + ": " + e.what() +
                               " (rosbag finds its plugins through ROS_PACKAGE_PATH: run with "
                               "rosrun or source the workspace's setup.bash)");
    }
  }
  rosbag::Bag& bag = *bag_owner;
  bag.setCompression(options.compression == BagCompression::kLz4 ? rosbag::compression::LZ4
                     : options.compression == BagCompression::kBz2
                         ? rosbag::compression::BZ2
                         : rosbag::compression::Uncompressed);
  const ros::Time begin =
      conversions::toRosTime(mission.startStamp() + core::fromSeconds(robot.start_offset_s));
  const std::string prefix = options.namespace_topics ? "/" + robot.name + "/" : "/";

  tf2_msgs::TFMessage mount;
  mount.transforms.push_back(conversions::toTransformStampedMsg(
      begin, robot.name + "/base_link", robot.name + "/velodyne", mission.sensorMount()));
  bag.write("/tf_static", begin, mount, latchedConnection<tf2_msgs::TFMessage>());
  bag.write(prefix + BagTopics::kWorld, begin,
            worldMarkers(mission.world(), robot.name + "/odom", robot.world_from_odom.inverse()),
            latchedConnection<visualization_msgs::MarkerArray>());

  BagSink sink(robot.name, !robot.aerial, prefix, &bag, &ground_truth, &stats);
  mission.record(index, sink);
  {
    std::lock_guard<std::mutex> lock(plugin_mutex);
    bag.close();
    bag_owner.reset();
  }
  ground_truth.close();
  stats.bag_bytes = std::filesystem::file_size(stats.bag_file);
  return stats;
}

void writeMissionFile(const Mission& mission, const std::vector<RobotRecording>& recordings,
                      const std::string& dir, const std::string& command_line) {
  const auto& world = mission.world();
  YAML::Emitter out;
  out.SetDoublePrecision(12);  // 0.3, not 0.29999999999999999
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << "ccir_mapping/mission 1";
  out << YAML::Key << "command" << YAML::Value << command_line;
  out << YAML::Key << "frames" << YAML::Value
      << "Each robot's data start at the origin of its own <robot>/odom frame (its true start "
         "pose); initial_pose_in_world places that frame in the world. Ground truth "
         "(<robot>_gt.txt, topic ground_truth) is the true pose of <robot>/base_link in "
         "<robot>/odom.";
  out << YAML::Key << "start_time_s" << YAML::Value << core::toSeconds(mission.startStamp());
  out << YAML::Key << "end_time_s" << YAML::Value << core::toSeconds(mission.endStamp());

  out << YAML::Key << "world" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "kind" << YAML::Value << world.kind();
  out << YAML::Key << "size_x_m" << YAML::Value << world.bounds().x_max - world.bounds().x_min;
  out << YAML::Key << "size_y_m" << YAML::Value << world.bounds().y_max - world.bounds().y_min;
  out << YAML::Key << "height_m" << YAML::Value << world.ceilingZ() - world.floorZ();
  out << YAML::Key << "boxes" << YAML::Value << world.boxes().size();
  out << YAML::Key << "cylinders" << YAML::Value << world.cylinders().size();
  out << YAML::Key << "walls" << YAML::Value << world.walls().size();
  out << YAML::Key << "road_nodes" << YAML::Value << world.roadMap().nodeCount();
  out << YAML::Key << "road_edges" << YAML::Value << world.roadMap().edgeCount();
  out << YAML::EndMap;

  out << YAML::Key << "parameters" << YAML::Value << YAML::BeginMap;
  YamlFields fields(&out);
  core::simulation::MissionParams::fields(mission.params(), fields);
  out << YAML::EndMap;

  out << YAML::Key << "robots" << YAML::Value << YAML::BeginSeq;
  for (size_t i = 0; i < mission.robots().size(); ++i) {
    const auto& robot = mission.robots()[i];
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << robot.name;
    out << YAML::Key << "kind" << YAML::Value << (robot.aerial ? "aerial" : "ground");
    out << YAML::Key << "start_time_s" << YAML::Value
        << core::toSeconds(mission.startStamp()) + robot.start_offset_s;
    out << YAML::Key << "initial_pose_in_world" << YAML::Value;
    emitPose(out, robot.world_from_odom);
    out << YAML::Key << "distance_m" << YAML::Value << robot.distance_m;
    out << YAML::Key << "shared_fraction" << YAML::Value << robot.shared_fraction;
    if (i < recordings.size()) {
      const auto& r = recordings[i];
      out << YAML::Key << "bag" << YAML::Value
          << std::filesystem::path(r.bag_file).filename().string();
      out << YAML::Key << "ground_truth" << YAML::Value
          << std::filesystem::path(r.ground_truth_file).filename().string();
      out << YAML::Key << "scans" << YAML::Value << r.scans;
      out << YAML::Key << "points" << YAML::Value << r.points;
      out << YAML::Key << "odometry_messages" << YAML::Value << r.odometry_messages;
      out << YAML::Key << "bag_bytes" << YAML::Value << r.bag_bytes;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;

  const std::string path = robotFile(dir, "mission.yaml");
  std::ofstream file(path);
  file << "# Simulated team mission written by simulate_team; replay each <robot>.bag with\n"
          "# rosbag play --clock.\n"
       << out.c_str() << '\n';
  if (!file) throw std::runtime_error("cannot write " + path);
}

visualization_msgs::MarkerArray worldMarkers(const core::simulation::World& world,
                                             const std::string& frame,
                                             const Pose3& frame_from_world) {
  visualization_msgs::MarkerArray markers;
  auto marker = [&](const std::string& ns, int type) {
    visualization_msgs::Marker m;
    m.header.frame_id = frame;
    m.ns = ns;
    m.id = static_cast<int>(markers.markers.size());
    m.type = type;
    m.action = visualization_msgs::Marker::ADD;
    m.color.r = 0.55F;
    m.color.g = 0.47F;
    m.color.b = 0.38F;
    m.color.a = 0.6F;
    m.pose.orientation.w = 1.0;
    return m;
  };
  auto place = [&](visualization_msgs::Marker& m, const Eigen::Vector3d& center, double yaw) {
    Pose3 pose = Pose3::Identity();
    pose.translation() = center;
    pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    m.pose = conversions::toPoseMsg(frame_from_world * pose);
  };

  const auto& b = world.bounds();
  if (b.x_max > b.x_min) {
    auto floor = marker("floor", visualization_msgs::Marker::CUBE);
    place(floor, {0.5 * (b.x_min + b.x_max), 0.5 * (b.y_min + b.y_max), world.floorZ() - 0.01},
          0.0);
    floor.scale.x = b.x_max - b.x_min;
    floor.scale.y = b.y_max - b.y_min;
    floor.scale.z = 0.02;
    floor.color.r = floor.color.g = floor.color.b = 0.35F;
    floor.color.a = 0.3F;
    markers.markers.push_back(floor);
  }
  for (const auto& box : world.boxes()) {
    auto m = marker("boxes", visualization_msgs::Marker::CUBE);
    place(m, {box.center.x(), box.center.y(), 0.5 * (box.z_min + box.z_max)},
          std::atan2(box.axis.y(), box.axis.x()));
    m.scale.x = 2 * box.half_size.x();
    m.scale.y = 2 * box.half_size.y();
    m.scale.z = box.z_max - box.z_min;
    markers.markers.push_back(m);
  }
  for (const auto& cylinder : world.cylinders()) {
    auto m = marker("cylinders", visualization_msgs::Marker::CYLINDER);
    place(m, {cylinder.center.x(), cylinder.center.y(), 0.5 * (cylinder.z_min + cylinder.z_max)},
          0.0);
    m.scale.x = m.scale.y = 2 * cylinder.radius;
    m.scale.z = cylinder.z_max - cylinder.z_min;
    markers.markers.push_back(m);
  }
  if (!world.walls().empty()) {
    auto m = marker("walls", visualization_msgs::Marker::TRIANGLE_LIST);
    m.pose = conversions::toPoseMsg(frame_from_world);
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    for (const auto& wall : world.walls()) {
      geometry_msgs::Point corners[4];
      const Eigen::Vector2d* ends[4] = {&wall.a, &wall.b, &wall.b, &wall.a};
      const double heights[4] = {wall.z_min, wall.z_min, wall.z_max, wall.z_max};
      for (int k = 0; k < 4; ++k) {
        corners[k].x = ends[k]->x();
        corners[k].y = ends[k]->y();
        corners[k].z = heights[k];
      }
      for (int k : {0, 1, 2, 0, 2, 3}) m.points.push_back(corners[k]);
    }
    markers.markers.push_back(m);
  }
  return markers;
}

}  // namespace ccir_mapping::simulation_io
