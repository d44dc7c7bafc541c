#include "bag_keyframes.h"

#include <filesystem>

#include <yaml-cpp/yaml.h>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>

#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/preprocess/preprocessor_stage.h"
#include "ccir_mapping/ros/conversions.h"

namespace core = ccir_mapping::core;
namespace conversions = ccir_mapping::conversions;

std::size_t forEachBagKeyframe(const std::string& bag_path, const BagKeyframeOptions& options,
                               const core::features::FeatureExtractor& extractor,
                               const std::function<void(BagKeyframe&&)>& consume) {
  constexpr double kOdometryToleranceS = 0.1;
  core::preprocess::PreprocessorParams params;
  params.keyframe_distance_m = options.keyframe_distance_m;
  params.keyframe_rotation_deg = 180.0;  // by distance only
  core::preprocess::PreprocessorStage stage{params};
  rosbag::Bag bag(bag_path);
  core::preprocess::OdometryBuffer odometry;
  core::preprocess::OdometryBuffer truth;
  std::vector<std::string> topics{options.odom_topic, options.points_topic};
  if (!options.truth_topic.empty()) topics.push_back(options.truth_topic);
  std::size_t count = 0;
  // In bag order: a driver publishes a scan when its sweep ends, after the odometry at its stamp
  // (the odometry buffer keeps only the recent past).
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topics))) {
    if (const auto odom = m.instantiate<nav_msgs::Odometry>()) {
      if (const auto pose = conversions::toPose(odom->pose.pose)) {
        (m.getTopic() == options.odom_topic ? odometry : truth)
            .add(conversions::toStamp(odom->header.stamp), *pose);
      }
      continue;
    }
    const auto cloud = m.instantiate<sensor_msgs::PointCloud2>();
    if (!cloud || conversions::checkCloud(*cloud, nullptr)) continue;
    BagKeyframe k;
    k.stamp = conversions::toStamp(cloud->header.stamp);
    const auto pose = odometry.at(k.stamp, kOdometryToleranceS);
    if (!pose) continue;
    if (!options.truth_topic.empty()) {
      k.true_pose = truth.at(k.stamp, kOdometryToleranceS);
      if (!k.true_pose) continue;
    }
    core::preprocess::PreprocessorStage::InputCloud scan;
    conversions::toPcl(*cloud, &scan);
    auto result = stage.process(k.stamp, *pose, scan);
    if (result.outcome != core::preprocess::PreprocessorStage::Outcome::kKeyframe) continue;
    k.odom_pose = *pose;
    k.cloud = std::move(result.cloud);
    k.features = extractor.extract(*k.cloud, core::upInFrame(*pose), &k.stats);
    consume(std::move(k));
    ++count;
  }
  return count;
}

std::vector<MissionBag> missionBags(const std::string& mission_dir) {
  const std::filesystem::path dir(mission_dir);
  std::vector<MissionBag> bags;
  try {
    const YAML::Node mission = YAML::LoadFile((dir / "mission.yaml").string());
    for (const YAML::Node& robot : mission["robots"]) {
      const YAML::Node p = robot["initial_pose_in_world"];
      MissionBag bag;
      bag.path = (dir / robot["bag"].as<std::string>()).string();
      bag.world_from_odom = core::Pose3::Identity();
      bag.world_from_odom.translation() << p["x"].as<double>(), p["y"].as<double>(),
          p["z"].as<double>();
      bag.world_from_odom.linear() = Eigen::Quaterniond(p["qw"].as<double>(), p["qx"].as<double>(),
                                                        p["qy"].as<double>(), p["qz"].as<double>())
                                         .normalized()
                                         .toRotationMatrix();
      bags.push_back(std::move(bag));
    }
  } catch (const YAML::Exception& e) {
    throw std::runtime_error((dir / "mission.yaml").string() + ": " + e.what());
  }
  return bags;
}
