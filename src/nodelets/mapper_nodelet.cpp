// Mapper: own keyframes and teammates' scans -> the robot's occupancy map (OctoMap), which follows
// the Backend's optimised poses by rebuilding (core/information/keyframe_map.h). Publishes the
// occupied voxels while someone listens and the map's entropy and known volume; saves the map on
// ~save_map and at shutdown; shares it in-process with the Broker (core/information/shared_map.h).
#include <chrono>
#include <cstdlib>
#include <thread>

#include <nav_msgs/Path.h>
#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_eigen/tf2_eigen.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/MapStats.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/information/keyframe_map.h"
#include "ccir_mapping/core/information/shared_map.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

namespace info = core::information;

class MapperNodelet final : public PipelineNodelet {
 public:
  ~MapperNodelet() override {
    if (rebuild_thread_.joinable()) rebuild_thread_.join();
    if (map_ && settings_.save_on_shutdown) save();
  }

 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    map_ = std::make_shared<info::SharedMap>(std::make_unique<info::OccupancyMap>(settings_.core));
    info::SharedMap::registerMap(settings_.frames.robot_name, map_);
    keyframes_ = std::make_unique<info::KeyframeMap>(settings_.core);
    map_path_ = settings_.map_path;
    if (map_path_.empty()) {
      const char* home = std::getenv("ROS_HOME");
      const char* user = std::getenv("HOME");
      map_path_ = (home ? std::string(home) : std::string(user ? user : ".") + "/.ros") + "/" +
                  settings_.frames.robot_name + "_map.bt";
    }
    ros::NodeHandle& nh = getNodeHandle();
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>(topics::kMapCloud, 1);
    stats_pub_ = nh.advertise<MapStats>(topics::kMapStats, topics::kMessageQueueSize);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &MapperNodelet::onKeyframe, this);
    teammate_scans_sub_ = nh.subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize,
                                       &MapperNodelet::onPeerScan, this);
    trajectory_sub_ = nh.subscribe(topics::kTrajectory, topics::kLatestOnlyQueueSize,
                                   &MapperNodelet::onTrajectory, this);
    team_sub_ = nh.subscribe(topics::kTeamTransforms, topics::kMessageQueueSize,
                             &MapperNodelet::onTeamTransform, this);
    save_srv_ = getPrivateNodeHandle().advertiseService("save_map", &MapperNodelet::onSave, this);
    createPeriodicTimer(settings_.core.publish_period_s,
                        [this] { measured("statistics", [this] { onTimer(); }); });
  }

  /// The keyframe's cloud (x y z) and odometry pose, or nullopt (warned, counted).
  std::optional<std::pair<std::shared_ptr<const info::Cloud>, core::Pose3>> scanOf(
      const Keyframe& keyframe, const char* flow) {
    auto cloud = std::make_shared<info::Cloud>();
    core::Pose3 pose;
    if (const auto error = conversions::toScanPoints(keyframe, cloud.get(), &pose)) {
      NODELET_WARN_THROTTLE(5.0, "dropping %s %lu of %s: %s", flow,
                            static_cast<unsigned long>(keyframe.id), keyframe.robot.c_str(),
                            error->c_str());
      count(std::string("dropped ") + flow);
      return std::nullopt;
    }
    return std::make_pair(std::shared_ptr<const info::Cloud>(std::move(cloud)), pose);
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes", keyframe->cloud.data.size());
    const auto scan = scanOf(*keyframe, "keyframe");
    if (!scan) return;
    std::lock_guard lock(mutex_);
    insert({keyframes_->addOwn(conversions::toStamp(keyframe->header.stamp), scan->first,
                               scan->second)});
  }

  void onPeerScan(const Keyframe::ConstPtr& keyframe) {
    count("in teammate_scans", keyframe->cloud.data.size());
    if (keyframe->robot == settings_.frames.robot_name) return;
    const auto scan = scanOf(*keyframe, "teammate scan");
    if (!scan) return;
    std::lock_guard lock(mutex_);
    if (keyframes_->holdsPeer(keyframe->robot, keyframe->id)) {
      count("dropped teammate_scans (held)");
      NODELET_WARN_THROTTLE(5.0, "ignoring %s's keyframe %lu: it is in the map already",
                            keyframe->robot.c_str(), static_cast<unsigned long>(keyframe->id));
      return;
    }
    insert(keyframes_->addPeer(keyframe->robot, keyframe->id, scan->first, scan->second));
  }

  void onTrajectory(const nav_msgs::Path::ConstPtr& path) {
    int skipped = 0;
    const auto poses = conversions::toStampedPoses(*path, &skipped);
    if (skipped > 0) NODELET_WARN_THROTTLE(5.0, "ignoring non-finite poses in the trajectory");
    std::lock_guard lock(mutex_);
    keyframes_->setOptimizedPoses(poses);
  }

  void onTeamTransform(const TeamTransform::ConstPtr& team) {
    if (!team->valid || team->peer == settings_.frames.robot_name) return;
    const auto transform = conversions::toPose(team->transform);
    if (!transform) {
      NODELET_WARN_THROTTLE(5.0, "ignoring a non-finite team transform to %s", team->peer.c_str());
      return;
    }
    std::lock_guard lock(mutex_);
    insert(keyframes_->setTeamTransform(team->peer, *transform));
  }

  /// Integrates placed scans (holding mutex_); during a rebuild they are also kept for the new
  /// map, which was started from an older list.
  void insert(const std::vector<info::PlacedScan>& scans) {
    for (const auto& scan : scans) {
      measured("insert",
               [&] { map_->write([&](info::OccupancyMap& map) { integrate(map, scan); }); });
      if (rebuilding_) placed_during_rebuild_.push_back(scan);
    }
  }

  static void integrate(info::OccupancyMap& map, const info::PlacedScan& scan) {
    map.insert(*scan.cloud, scan.map_from_sensor);
  }

  void onTimer() {
    startRebuildIfDue();
    auto stats = boost::make_shared<MapStats>();
    stats->header.stamp = ros::Time::now();
    stats->header.frame_id = settings_.frames.map_frame;
    stats->robot = settings_.frames.robot_name;
    stats->resolution_m = settings_.core.resolution_m;
    map_->read([&](const info::OccupancyMap& map) {
      stats->entropy_bits = map.boxEntropyBits();
      stats->known_volume_m3 = map.boxKnownVolumeM3();
      return 0;
    });
    stats->box_min = tf2::toMsg(settings_.core.entropyBoxMin());
    stats->box_max = tf2::toMsg(settings_.core.entropyBoxMax());
    {
      std::lock_guard lock(mutex_);
      stats->keyframes = static_cast<std::uint32_t>(keyframes_->ownKeyframes());
      stats->peer_scans = static_cast<std::uint32_t>(keyframes_->peerScans());
      stats->pending_peer_scans = static_cast<std::uint32_t>(keyframes_->pendingPeerScans());
      stats->rebuilds = rebuilds_;
    }
    stats_pub_.publish(stats);
    count("out map_stats");
    if (cloud_pub_.getNumSubscribers() > 0) publishCloud(stats->header);
  }

  void publishCloud(const std_msgs::Header& header) {
    const auto occupied =
        map_->read([](const info::OccupancyMap& map) { return map.occupiedCentres(); });
    auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
    pcl::toROSMsg(occupied, *cloud);
    cloud->header = header;
    cloud_pub_.publish(cloud);
    count("out map_cloud", cloud->data.size());
  }

  /// Rebuilds the map at the current poses in a worker thread, then swaps it in.
  void startRebuildIfDue() {
    std::lock_guard lock(mutex_);
    if (rebuilding_ || !keyframes_->rebuildDue()) return;
    if (rebuild_thread_.joinable()) rebuild_thread_.join();
    rebuilding_ = true;
    rebuild_thread_ = std::thread([this, scans = keyframes_->placeAll()] {
      const auto start = std::chrono::steady_clock::now();
      auto fresh = std::make_unique<info::OccupancyMap>(settings_.core);
      measured("rebuild", [&] {
        for (const auto& scan : scans) integrate(*fresh, scan);
      });
      std::lock_guard lock(mutex_);
      for (const auto& scan : placed_during_rebuild_) integrate(*fresh, scan);
      placed_during_rebuild_.clear();
      map_->replace(std::move(fresh));
      rebuilding_ = false;
      ++rebuilds_;
      NODELET_INFO("map rebuilt at the optimised poses from %zu scans in %.1f s", scans.size(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    });
  }

  bool save() {
    const bool ok = map_->write([&](info::OccupancyMap& map) { return map.save(map_path_); });
    if (ok) {
      NODELET_INFO("map saved to %s", map_path_.c_str());
    } else {
      NODELET_ERROR("could not write the map to %s (~map_path)", map_path_.c_str());
    }
    return ok;
  }

  bool onSave(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
    response.success = save();
    response.message = (response.success ? "saved " : "could not write ") + map_path_;
    return true;
  }

  ros_params::MapperSettings settings_;
  std::string map_path_;
  std::shared_ptr<info::SharedMap> map_;
  /// Guards keyframes_, rebuilding_, placed_during_rebuild_ and rebuilds_.
  std::mutex mutex_;
  std::unique_ptr<info::KeyframeMap> keyframes_;
  bool rebuilding_ = false;
  std::vector<info::PlacedScan> placed_during_rebuild_;
  std::uint32_t rebuilds_ = 0;
  std::thread rebuild_thread_;
  ros::Publisher cloud_pub_;
  ros::Publisher stats_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber teammate_scans_sub_;
  ros::Subscriber trajectory_sub_;
  ros::Subscriber team_sub_;
  ros::ServiceServer save_srv_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::MapperNodelet, nodelet::Nodelet)
