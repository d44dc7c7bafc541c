#include "bag_keyframes.h"

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>

#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/ros/conversions.h"

namespace core = ccir_mapping::core;
namespace conversions = ccir_mapping::conversions;

std::size_t forEachBagKeyframe(const std::string& bag_path, const BagKeyframeOptions& options,
                               const core::features::FeatureExtractor& extractor,
                               const std::function<void(BagKeyframe&&)>& consume) {
  constexpr double kOdometryToleranceS = 0.1;
  const core::preprocess::ScanPreprocessor preprocessor{core::preprocess::PreprocessorParams{}};
  rosbag::Bag bag(bag_path);
  core::preprocess::OdometryBuffer odometry;
  core::preprocess::OdometryBuffer truth;
  core::preprocess::KeyframeSelector selector({options.keyframe_distance_m, M_PI});
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
    if (selector.offer(k.stamp, *pose).outcome !=
        core::preprocess::KeyframeSelector::Outcome::kKeyframe) {
      continue;
    }
    k.odom_pose = *pose;
    pcl::PointCloud<pcl::PointXYZI> scan;
    conversions::toPcl(*cloud, &scan);
    const Eigen::Vector3f up =
        (pose->linear().transpose() * Eigen::Vector3d::UnitZ()).cast<float>();
    k.cloud = preprocessor.process(scan, up);
    k.features = extractor.extract(*k.cloud, up);
    consume(std::move(k));
    ++count;
  }
  return count;
}
