// Keyframes of a recorded mission, selected and described as the pipeline does: the input both
// train_place_model and eval_place_recognition need.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/features/feature_extractor.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"

struct BagKeyframe {
  ccir_mapping::core::Stamp stamp;
  ccir_mapping::core::Pose3 odom_pose;
  std::optional<ccir_mapping::core::Pose3> true_pose;  // set when a truth topic is read
  ccir_mapping::core::preprocess::ScanPreprocessor::OutputCloud::Ptr cloud;
  ccir_mapping::core::features::LocalFeatures features;
  ccir_mapping::core::features::ExtractionStats stats;
};

struct BagKeyframeOptions {
  std::string points_topic = "/velodyne_points";
  std::string odom_topic = "/odom";
  std::string truth_topic;  // empty: no ground truth; otherwise scans without it are skipped
  double keyframe_distance_m = 2.0;
};

/// Reads `bag_path` in bag order, takes a keyframe every `keyframe_distance_m` of odometry
/// through the Preprocessor's stage (core::preprocess::PreprocessorStage, default parameters
/// otherwise), describes it, and hands it to `consume`. Returns the number of keyframes;
/// malformed clouds and scans without odometry are skipped. Throws rosbag::BagException when the
/// bag cannot be read.
std::size_t forEachBagKeyframe(const std::string& bag_path, const BagKeyframeOptions& options,
                               const ccir_mapping::core::features::FeatureExtractor& extractor,
                               const std::function<void(BagKeyframe&&)>& consume);

/// One robot of a simulate_team output: its bag and where its odometry frame starts in the world.
struct MissionBag {
  std::string path;
  ccir_mapping::core::Pose3 world_from_odom;
};

/// The robots listed in `mission_dir`/mission.yaml, in its order. Throws std::runtime_error when
/// the file cannot be read or lacks a robot's bag or initial pose.
std::vector<MissionBag> missionBags(const std::string& mission_dir);
