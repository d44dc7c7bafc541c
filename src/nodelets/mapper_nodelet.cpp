// Mapper: own keyframes and teammates' scans -> the robot's occupancy map (OctoMap), which follows
// the Backend's optimised poses (own and, from the team graph, teammates') by moving submaps
// (core/information/mapper_stage.h). Publishes the occupied voxels while someone listens and the
// map's entropy and known volume; saves the map on ~save_map and at shutdown (save_dir); shares
// it in-process with the Broker (core/information/shared_map.h).
#include <nav_msgs/Path.h>
#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/PointCloud2.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/core/information/mapper_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

namespace info = core::information;

class MapperNodelet final : public PipelineNodelet {
 public:
  ~MapperNodelet() override { saveAtShutdown(); }

 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    info::MapperStage::Hooks hooks;
    hooks.run = [this](const char* stage, const auto& work) { measured(stage, work); };
    stage_ =
        std::make_unique<info::MapperStage>(settings_.frames.robot_name, settings_.core, hooks);
    try {
      if (settings_.save.resume && stage_->resume(settings_.save.dir)) {
        NODELET_INFO("resuming the map saved in %s", settings_.save.dir.c_str());
      }
    } catch (const std::exception& e) {
      stage_.reset();  // inert, and nothing saved over the file at shutdown (nothing served)
      return failConfiguration(std::string(e.what()) + " (save_dir, resume)");
    }
    info::SharedMap::registerMap(getName(), stage_->map());  // for the Broker (its `mapper`)
    advertise<sensor_msgs::PointCloud2>(topics::kMapCloud, 1);
    advertise<MapStats>(topics::kMapStats, topics::kMessageQueueSize);
    subscribe(topics::kKeyframes, topics::kKeyframeQueueSize, &MapperNodelet::onKeyframe);
    subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize, &MapperNodelet::onPeerScan);
    subscribe(topics::kTrajectory, topics::kLatestOnlyQueueSize, &MapperNodelet::onTrajectory);
    subscribe(topics::kTeamTransforms, topics::kMessageQueueSize, &MapperNodelet::onTeamTransform);
    subscribe(topics::kTeamKeyframePoses, topics::kMessageQueueSize, &MapperNodelet::onPeerPoses);
    serveSaving("save_map", settings_.save,
                [this] { return std::optional(std::vector{stage_->save(settings_.save.dir)}); });
    createPeriodicTimer(settings_.core.publish_period_s, [this] {
      // Measured as "reanchor" by the stage; the cost is paid in wall time.
      stage_->followPoses(ros::SteadyTime::now().toSec());
      measured("statistics", [this] { onTimer(); });
    });
  }

  /// The keyframe's cloud (x y z) and odometry pose, or nullopt (dropped from `flow`).
  std::optional<std::pair<std::shared_ptr<const info::Cloud>, core::Pose3>> scanOf(
      const Keyframe& keyframe, const char* flow, const char* what) {
    auto cloud = std::make_shared<info::Cloud>();
    core::Pose3 pose;
    if (const auto error = conversions::toScanPoints(keyframe, cloud.get(), &pose)) {
      drop(flow, "dropping %s %lu of %s: %s", what, static_cast<unsigned long>(keyframe.id),
           keyframe.robot.c_str(), error->c_str());
      return std::nullopt;
    }
    return std::make_pair(std::shared_ptr<const info::Cloud>(std::move(cloud)), pose);
  }

  void onKeyframe(const Keyframe& keyframe) {
    if (const auto scan = scanOf(keyframe, "keyframes", "keyframe")) {
      stage_->addOwn(conversions::toStamp(keyframe.header.stamp), scan->first, scan->second);
    }
  }

  void onPeerScan(const Keyframe& keyframe) {
    const auto scan = scanOf(keyframe, "teammate_scans", "teammate scan");
    if (!scan) return;
    if (const auto why = stage_->addPeer(keyframe.robot, keyframe.id, scan->first, scan->second)) {
      drop("teammate_scans (not added)", "ignoring %s's keyframe %lu: %s", keyframe.robot.c_str(),
           static_cast<unsigned long>(keyframe.id), why->c_str());
    }
  }

  void onTrajectory(const nav_msgs::Path& path) {
    int skipped = 0;
    stage_->setOptimizedPoses(conversions::toStampedPoses(path, &skipped));
    if (skipped > 0) NODELET_WARN_THROTTLE(5.0, "ignoring non-finite poses in the trajectory");
  }

  void onTeamTransform(const TeamTransform& team) {
    if (const auto transform = conversions::toTeamFrame(team)) {
      stage_->setTeamTransform(team.peer, *transform);
    } else if (team.valid) {
      NODELET_WARN_THROTTLE(5.0, "ignoring a non-finite team transform to %s", team.peer.c_str());
    }
  }

  void onPeerPoses(const TeamKeyframePoses& msg) {
    if (const auto poses = conversions::toKeyframePoses(msg)) {
      stage_->setPeerPoses(msg.robot, *poses);
    } else {
      drop("team_keyframe_poses",
           "ignoring %s's keyframe poses: lengths differ or a pose is "
           "not finite",
           msg.robot.c_str());
    }
  }

  void onTimer() {
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = settings_.frames.map_frame;
    publish(topics::kMapStats,
            boost::make_shared<const MapStats>(conversions::toMapStatsMsg(
                stage_->stats(), settings_.core, settings_.frames.robot_name, header)));
    if (!listened(topics::kMapCloud)) return;
    auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
    pcl::toROSMsg(stage_->map()->read([](const auto& map) { return map.occupiedCentres(); }),
                  *cloud);
    cloud->header = header;
    publish(topics::kMapCloud, boost::shared_ptr<const sensor_msgs::PointCloud2>(cloud));
  }

  ros_params::MapperSettings settings_;
  std::unique_ptr<info::MapperStage> stage_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MapperNodelet, nodelet::Nodelet)
