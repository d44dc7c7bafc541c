// Preprocessor: velodyne_points + odometry -> keyframes. Thin: checks input, places each scan
// with odometry, lets the core decide keyframes and filter them, publishes them zero-copy.
#include <map>
#include <mutex>

#include <dynamic_reconfigure/server.h>
#include <nav_msgs/Odometry.h>
#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_listener.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/core/preprocess/keyframe_stage.h"
#include "ccir_mapping/core/preprocess/ordered_wait_queue.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/scan_placement.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::preprocess::KeyframeStage;

class PreprocessorNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    stage_ = std::make_unique<KeyframeStage>(settings_.core);
    placement_ = std::make_unique<ScanPlacement>(settings_, nh.resolveName(topics::kOdometry));
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(placement_->tf(), nh);

    keyframe_pub_ = nh.advertise<Keyframe>(topics::kKeyframes, topics::kKeyframeQueueSize);
    if (settings_.odom_source == "topic") {
      odom_sub_ = nh.subscribe(topics::kOdometry, 100, &PreprocessorNodelet::onOdometry, this);
    }
    cloud_sub_ = nh.subscribe(topics::kVelodynePoints, settings_.scan_queue_size,
                              &PreprocessorNodelet::onCloud, this);
    if (settings_.odom_source == "tf") {
      // tf arrives on the listener's own thread: look again for scans it can now place.
      // (tf2_ros::MessageFilter would wait too, but stalled scans in this pipeline's tests.)
      tf_poll_timer_ = nh.createSteadyTimer(ros::WallDuration(0.02), [this](const auto&) {
        std::lock_guard<std::mutex> lock(mutex_);
        drainPending();
      });
    }

    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<PreprocessorConfig>>(
        reconfigure_mutex_, getPrivateNodeHandle());
    reconfigure_->setCallback(
        [this](PreprocessorConfig& config, uint32_t) { onReconfigure(config); });
  }

  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
    count("in odom");
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto refusal = placement_->addOdometry(*msg)) {
      warnPerProblem("odometry", msg->header.stamp, refusal->problem, refusal->detail);
      count("dropped odom");
      return;
    }
    drainPending();
  }

  bool placeable(const sensor_msgs::PointCloud2& cloud, std::string* why = nullptr) const {
    return placement_->placeable(cloud.header.frame_id, cloud.header.stamp, why);
  }

  // Places every scan that can be placed now, in order. Holds mutex_.
  void drainPending() {
    pending_.drain(
        [this](const auto& cloud) { return placeable(*cloud); },
        [this](const auto& cloud) { process(cloud); },
        [this](const auto& cloud) { dropUnplaceable(*cloud, "a later scan was placed first"); });
  }

  void dropUnplaceable(const sensor_msgs::PointCloud2& cloud, const char* context) {
    std::string why;
    placeable(cloud, &why);
    NODELET_WARN_THROTTLE(5.0, "dropping cloud at %.3f in frame '%s': cannot place it (%s): %s",
                          cloud.header.stamp.toSec(), cloud.header.frame_id.c_str(), context,
                          why.c_str());
    count("dropped scans");
  }

  void onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    measured("scans", [&] { takeCloud(msg); });
  }

  void takeCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    count("in velodyne_points", msg->data.size());
    conversions::CloudFields fields;
    if (const auto error = conversions::checkCloud(*msg, &fields)) {
      return dropScan(*msg, "malformed", *error);
    }
    warnAboutMissingFields(fields);
    if (msg->header.frame_id.empty()) return dropScan(*msg, "empty frame_id");
    std::lock_guard<std::mutex> lock(mutex_);
    std::uint64_t missing = 0;
    if (!stage_->arrive(conversions::toStamp(msg->header.stamp), &missing)) {
      return dropScan(*msg, kStampNotIncreasing);
    }
    if (missing) {
      NODELET_WARN_THROTTLE(5.0,
                            "%lu scan(s) missing before %.3f (%lu so far): the sensor queue "
                            "overflowed while the pipeline was busy, or the driver or bag lost "
                            "them; replay slower (rosbag play -r) if this machine cannot keep up",
                            static_cast<unsigned long>(missing), msg->header.stamp.toSec(),
                            static_cast<unsigned long>(stage_->totals().missed_scans));
    }
    if (const auto pushed_out = pending_.push(msg)) {
      dropUnplaceable(**pushed_out, "waited too long");
    }
    drainPending();
  }

  // Places a checked scan with odometry and publishes it if it makes a keyframe. Holds mutex_.
  void process(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    std::string why;
    const auto pose = placement_->sensorPose(msg->header.frame_id, msg->header.stamp, &why);
    if (!pose) return dropScan(*msg, "cannot place it", why);

    conversions::toPcl(*msg, &scan_);
    const auto result = stage_->process(conversions::toStamp(msg->header.stamp), *pose, scan_);
    const auto& stats = result.stats;
    if (msg->height == 1 && stats.not_finite > 0) {
      NODELET_WARN_THROTTLE(10.0,
                            "cloud at %.3f: %zu of %zu points are NaN, infinite or zero in an "
                            "unorganised cloud (expected only in organised ones); they are skipped",
                            msg->header.stamp.toSec(), stats.not_finite, stats.points_in);
    }
    switch (result.outcome) {
      case KeyframeStage::Outcome::kSkipped:
        return;
      case KeyframeStage::Outcome::kTooFewPoints:
        NODELET_WARN_THROTTLE(5.0,
                              "dropping cloud at %.3f: only %zu of %zu points are finite and "
                              "within [%g, %g] m (min_points %d)",
                              msg->header.stamp.toSec(), result.usable_points, stats.points_in,
                              settings_.core.min_range_m, settings_.core.max_range_m,
                              settings_.core.min_points);
        count("dropped scans");
        return;
      case KeyframeStage::Outcome::kStampNotIncreasing:
        return dropScan(*msg, kStampNotIncreasing);
      case KeyframeStage::Outcome::kInvalidPose:
        return dropScan(*msg, "its pose is not finite");
      case KeyframeStage::Outcome::kKeyframe:
        break;
    }
    if (result.cloud->empty()) {
      NODELET_WARN_THROTTLE(5.0,
                            "keyframe %lu at %.3f has no point left after preprocessing (%zu in "
                            "range, %zu without a normal, %zu horizontal, %zu outside the slice)",
                            static_cast<unsigned long>(result.decision.id),
                            msg->header.stamp.toSec(),
                            stats.points_in - stats.not_finite - stats.out_of_range,
                            stats.without_normal, stats.horizontal, stats.outside_slice);
    }
    auto keyframe = boost::make_shared<Keyframe>();
    keyframe->header = msg->header;
    keyframe->robot = settings_.frames.robot_name;
    keyframe->id = result.decision.id;
    keyframe->odom_frame = settings_.frames.odom_frame;
    keyframe->odom_pose = conversions::toPoseMsg(*pose);
    keyframe->travelled_m = static_cast<float>(result.decision.travelled_m);
    keyframe->rotated_rad = static_cast<float>(result.decision.rotated_rad);
    pcl::toROSMsg(*result.cloud, keyframe->cloud);
    keyframe->cloud.header = msg->header;
    count("out keyframes", keyframe->cloud.data.size());
    keyframe_pub_.publish(keyframe);
  }

  void dropScan(const sensor_msgs::PointCloud2& cloud, const std::string& problem,
                const std::string& detail = "") {
    count("dropped scans");
    warnPerProblem("cloud", cloud.header.stamp, problem, detail);
  }

  /// "dropping <what> at <stamp>: <problem>[: <detail>]", once per 5 s for each problem (one
  /// throttle per call site would hide all but the first kind of bad input).
  void warnPerProblem(const char* what, const ros::Time& stamp, const std::string& problem,
                      const std::string& detail) {
    const ros::WallTime now = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(warned_mutex_);  // called with and without mutex_
    auto& last = last_warned_[std::string(what) + problem];
    if (!last.isZero() && (now - last).toSec() < 5.0) return;
    last = now;
    NODELET_WARN("dropping %s at %.3f: %s%s%s", what, stamp.toSec(), problem.c_str(),
                 detail.empty() ? "" : ": ", detail.c_str());
  }

  void onReconfigure(PreprocessorConfig& config) {
    // The server already holds reconfigure_mutex_; mutex_ guards what callbacks read.
    std::lock_guard<std::mutex> lock(mutex_);
    const auto outcome = ros_params::preprocessorReconfigure().apply(config, settings_.core);
    if (outcome.error) {
      NODELET_ERROR("reconfigure rejected: %s", outcome.error->c_str());
      return;
    }
    if (!outcome.changes.empty()) NODELET_INFO("reconfigured:%s", outcome.changes.c_str());
    settings_.core = outcome.params;
    stage_->setParams(outcome.params);
  }

  // Once a minute at most: optional fields of the Velodyne layout that the clouds lack.
  void warnAboutMissingFields(const conversions::CloudFields& fields) {
    std::string missing;
    if (!fields.intensity) missing += " intensity";
    if (!fields.ring) missing += " ring";
    if (!fields.time) missing += " time";
    if (missing.empty()) return;
    NODELET_WARN_THROTTLE(60.0,
                          "clouds on %s lack the field(s)%s of the Velodyne driver's layout (x y "
                          "z intensity ring time); keyframes are made from what is there%s",
                          getNodeHandle().resolveName(topics::kVelodynePoints).c_str(),
                          missing.c_str(), fields.intensity ? "" : " (intensity 0)");
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!stage_) return;
    const auto& totals = stage_->totals();
    status.add("missed scans (gaps in stamps)", totals.missed_scans);
    status.add("keyframe points in (last)", totals.last_points_in);
    status.add("keyframe points out (last)", totals.last_points_out);
    status.addf("ms per keyframe (mean)", "%.1f",
                totals.keyframes ? totals.total_filter_ms / totals.keyframes : 0.0);
    status.addf("ms per keyframe (max)", "%.1f", totals.max_filter_ms);
  }

  static constexpr char kStampNotIncreasing[] =
      "stamp not after the previous scan (a bag replayed again? restart the pipeline)";
  // Two seconds of VLP-16 scans at 10 Hz.
  static constexpr std::size_t kMaxPendingScans = 20;

  ros_params::PreprocessorSettings settings_;
  std::mutex mutex_;  // guards everything below that callbacks touch
  // Scans waiting for odometry or tf, in stamp order.
  core::preprocess::OrderedWaitQueue<sensor_msgs::PointCloud2::ConstPtr> pending_{kMaxPendingScans};
  std::unique_ptr<KeyframeStage> stage_;
  std::mutex warned_mutex_;                           // guards last_warned_
  std::map<std::string, ros::WallTime> last_warned_;  // by problem
  KeyframeStage::InputCloud scan_;                    // conversion buffer, reused scan after scan
  std::unique_ptr<ScanPlacement> placement_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Publisher keyframe_pub_;
  ros::Subscriber odom_sub_;
  ros::Subscriber cloud_sub_;
  ros::SteadyTimer tf_poll_timer_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<PreprocessorConfig>> reconfigure_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::PreprocessorNodelet, nodelet::Nodelet)
