// Preprocessor: velodyne_points + odometry -> keyframes. Thin: checks input, places each scan
// with odometry, lets the core decide keyframes and filter them, publishes them zero-copy.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>

#include <dynamic_reconfigure/server.h>
#include <nav_msgs/Odometry.h>
#include <pcl_conversions/pcl_conversions.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/core/preprocess/keyframe_selector.h"
#include "ccir_mapping/core/preprocess/odometry_buffer.h"
#include "ccir_mapping/core/preprocess/ordered_wait_queue.h"
#include "ccir_mapping/core/preprocess/scan_gap_counter.h"
#include "ccir_mapping/core/preprocess/scan_preprocessor.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::preprocess::KeyframeSelector;
using core::preprocess::PreprocessStats;
using core::preprocess::ScanPreprocessor;

class PreprocessorNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    selector_ = std::make_unique<KeyframeSelector>(selectorParams(settings_.core));
    preprocessor_ = std::make_unique<ScanPreprocessor>(settings_.core);
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh);

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

  static KeyframeSelector::Params selectorParams(const core::preprocess::PreprocessorParams& p) {
    return {p.keyframe_distance_m, p.keyframe_rotation_deg * M_PI / 180.0};
  }

  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
    count("in odom");
    if (msg->header.frame_id != settings_.frames.odom_frame ||
        msg->child_frame_id != settings_.frames.base_frame) {
      NODELET_WARN_THROTTLE(5.0, "dropping odometry in frames '%s' -> '%s': expected '%s' -> '%s'",
                            msg->header.frame_id.c_str(), msg->child_frame_id.c_str(),
                            settings_.frames.odom_frame.c_str(),
                            settings_.frames.base_frame.c_str());
      count("dropped odom");
      return;
    }
    const auto pose = conversions::toPose(msg->pose.pose);
    std::lock_guard<std::mutex> lock(mutex_);
    if (!pose || !odometry_.add(conversions::toStamp(msg->header.stamp), *pose)) {
      NODELET_WARN_THROTTLE(5.0, "dropping odometry at %.3f: %s", msg->header.stamp.toSec(),
                            pose ? "stamp not after the previous one" : "pose is not finite");
      count("dropped odom");
      return;
    }
    drainPending();
  }

  // True once what places the scan has arrived: tf from the sensor frame to the odom frame at
  // its stamp, or odometry at or after its stamp plus the sensor mount. Otherwise says why in
  // `why` (when given). Holds mutex_.
  bool placeable(const sensor_msgs::PointCloud2& cloud, std::string* why = nullptr) {
    const std::string& sensor = cloud.header.frame_id;
    if (settings_.odom_source == "tf") {
      return tf_buffer_.canTransform(settings_.frames.odom_frame, sensor, cloud.header.stamp, why);
    }
    const auto newest = odometry_.newestStamp();
    if (!newest || conversions::toStamp(cloud.header.stamp) > *newest) {
      if (why) {
        *why = "no odometry at or after its stamp on '" +
               getNodeHandle().resolveName(topics::kOdometry) + "'";
      }
      return false;
    }
    return sensor == settings_.frames.base_frame ||
           tf_buffer_.canTransform(settings_.frames.base_frame, sensor, ros::Time(0), why);
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

  // Pose of the sensor frame in the odom frame at the scan stamp, or an explanation.
  std::optional<core::Pose3> sensorPose(const sensor_msgs::PointCloud2& cloud, std::string& why) {
    const std::string& sensor = cloud.header.frame_id;
    try {
      if (settings_.odom_source == "tf") {
        return tf2::transformToEigen(
            tf_buffer_.lookupTransform(settings_.frames.odom_frame, sensor, cloud.header.stamp));
      }
      const std::optional<core::Pose3> base =
          odometry_.at(conversions::toStamp(cloud.header.stamp), settings_.core.odom_tolerance_s);
      if (!base) {
        why = "no odometry within odom_tolerance_s of the scan";
        return std::nullopt;
      }
      if (sensor == settings_.frames.base_frame) return base;
      // The sensor mount is static: the latest transform is the right one.
      return *base * tf2::transformToEigen(tf_buffer_.lookupTransform(settings_.frames.base_frame,
                                                                      sensor, ros::Time(0)));
    } catch (const tf2::TransformException& e) {
      why = e.what();
      return std::nullopt;
    }
  }

  void onCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    measured("scans", [&] { takeCloud(msg); });
  }

  void takeCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    count("in velodyne_points", msg->data.size());
    conversions::CloudFields fields;
    if (const auto error = conversions::checkCloud(*msg, &fields)) {
      NODELET_WARN_THROTTLE(5.0, "dropping malformed cloud at %.3f: %s", msg->header.stamp.toSec(),
                            error->c_str());
      count("dropped scans");
      return;
    }
    warnAboutMissingFields(fields);
    if (msg->header.frame_id.empty()) {
      NODELET_WARN_THROTTLE(5.0, "dropping cloud at %.3f: empty frame_id",
                            msg->header.stamp.toSec());
      count("dropped scans");
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (last_queued_stamp_ && msg->header.stamp <= *last_queued_stamp_) {
      NODELET_WARN_THROTTLE(5.0,
                            "dropping cloud at %.3f: stamp not after the previous scan (a bag "
                            "replayed again? restart the pipeline)",
                            msg->header.stamp.toSec());
      count("dropped scans");
      return;
    }
    last_queued_stamp_ = msg->header.stamp;
    if (const std::uint64_t missing = gaps_.add(conversions::toStamp(msg->header.stamp))) {
      NODELET_WARN_THROTTLE(5.0,
                            "%lu scan(s) missing before %.3f (%lu so far): the sensor queue "
                            "overflowed while the pipeline was busy, or the driver or bag lost "
                            "them; replay slower (rosbag play -r) if this machine cannot keep up",
                            static_cast<unsigned long>(missing), msg->header.stamp.toSec(),
                            static_cast<unsigned long>(gaps_.missed()));
      missed_scans_ = gaps_.missed();
    }
    if (const auto pushed_out = pending_.push(msg)) {
      dropUnplaceable(**pushed_out, "waited too long");
    }
    drainPending();
  }

  // Places a checked scan with odometry and publishes it if it makes a keyframe. Holds mutex_.
  void process(const sensor_msgs::PointCloud2::ConstPtr& msg) {
    std::string why;
    const auto pose = sensorPose(*msg, why);
    if (!pose) {
      NODELET_WARN_THROTTLE(5.0, "dropping cloud at %.3f: cannot place it: %s",
                            msg->header.stamp.toSec(), why.c_str());
      count("dropped scans");
      return;
    }

    // Enough usable points, before the scan may take a keyframe's place.
    conversions::toPcl(*msg, &scan_);
    PreprocessStats counted;
    const std::size_t usable = preprocessor_->usablePoints(scan_, &counted);
    if (msg->height == 1 && counted.not_finite > 0) {
      NODELET_WARN_THROTTLE(10.0,
                            "cloud at %.3f: %zu of %zu points are NaN, infinite or zero in an "
                            "unorganised cloud (expected only in organised ones); they are skipped",
                            msg->header.stamp.toSec(), counted.not_finite, counted.points_in);
    }
    if (usable < static_cast<std::size_t>(settings_.core.min_points)) {
      NODELET_WARN_THROTTLE(5.0,
                            "dropping cloud at %.3f: only %zu of %zu points are finite and within "
                            "[%g, %g] m (min_points %d)",
                            msg->header.stamp.toSec(), usable, counted.points_in,
                            settings_.core.min_range_m, settings_.core.max_range_m,
                            settings_.core.min_points);
      count("dropped scans");
      return;
    }

    const KeyframeSelector::Decision decision =
        selector_->offer(conversions::toStamp(msg->header.stamp), *pose);
    switch (decision.outcome) {
      case KeyframeSelector::Outcome::kSkipped:
        return;
      case KeyframeSelector::Outcome::kStampNotIncreasing:
        NODELET_WARN_THROTTLE(5.0,
                              "dropping cloud at %.3f: stamp not after the previous scan (a bag "
                              "replayed again? restart the pipeline)",
                              msg->header.stamp.toSec());
        count("dropped scans");
        return;
      case KeyframeSelector::Outcome::kInvalidPose:
        NODELET_WARN_THROTTLE(5.0, "dropping cloud at %.3f: its pose is not finite",
                              msg->header.stamp.toSec());
        count("dropped scans");
        return;
      case KeyframeSelector::Outcome::kKeyframe:
        break;
    }

    auto keyframe = boost::make_shared<Keyframe>();
    keyframe->header = msg->header;
    keyframe->robot = settings_.frames.robot_name;
    keyframe->id = decision.id;
    keyframe->odom_frame = settings_.frames.odom_frame;
    keyframe->odom_pose = conversions::toPoseMsg(*pose);
    keyframe->travelled_m = static_cast<float>(decision.travelled_m);
    keyframe->rotated_rad = static_cast<float>(decision.rotated_rad);
    // Gravity is "up" in the odom frame; the core wants it in the sensor frame.
    const Eigen::Vector3f up =
        (pose->linear().transpose() * Eigen::Vector3d::UnitZ()).cast<float>();
    PreprocessStats stats;
    const auto start = std::chrono::steady_clock::now();
    const ScanPreprocessor::OutputCloud::Ptr cloud = preprocessor_->process(scan_, up, &stats);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    pcl::toROSMsg(*cloud, keyframe->cloud);
    keyframe->cloud.header = msg->header;
    if (cloud->empty()) {
      NODELET_WARN_THROTTLE(5.0,
                            "keyframe %lu at %.3f has no point left after preprocessing (%zu in "
                            "range, %zu without a normal, %zu horizontal, %zu outside the slice)",
                            static_cast<unsigned long>(decision.id), msg->header.stamp.toSec(),
                            stats.points_in - stats.not_finite - stats.out_of_range,
                            stats.without_normal, stats.horizontal, stats.outside_slice);
    }
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      last_points_in_ = stats.points_in;
      last_points_out_ = stats.points_out;
      total_ms_ += ms;
      max_ms_ = std::max(max_ms_, ms);
      ++processed_;
    }
    count("out keyframes", keyframe->cloud.data.size());
    keyframe_pub_.publish(keyframe);
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
    selector_->setParams(selectorParams(outcome.params));
    preprocessor_ = std::make_unique<ScanPreprocessor>(outcome.params);
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
    status.add("missed scans (gaps in stamps)", missed_scans_.load());
    std::lock_guard<std::mutex> lock(stats_mutex_);
    status.add("keyframe points in (last)", last_points_in_);
    status.add("keyframe points out (last)", last_points_out_);
    status.addf("ms per keyframe (mean)", "%.1f", processed_ ? total_ms_ / processed_ : 0.0);
    status.addf("ms per keyframe (max)", "%.1f", max_ms_);
  }

  // Two seconds of VLP-16 scans at 10 Hz.
  static constexpr std::size_t kMaxPendingScans = 20;

  ros_params::PreprocessorSettings settings_;
  std::mutex mutex_;  // guards everything below that callbacks touch
  // Scans waiting for odometry or tf, in stamp order.
  core::preprocess::OrderedWaitQueue<sensor_msgs::PointCloud2::ConstPtr> pending_{kMaxPendingScans};
  std::optional<ros::Time> last_queued_stamp_;
  core::preprocess::ScanGapCounter gaps_;
  std::atomic<std::uint64_t> missed_scans_{0};  // for diagnostics
  std::unique_ptr<KeyframeSelector> selector_;
  std::unique_ptr<ScanPreprocessor> preprocessor_;
  ScanPreprocessor::InputCloud scan_;  // conversion buffer, reused scan after scan
  core::preprocess::OdometryBuffer odometry_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Publisher keyframe_pub_;
  ros::Subscriber odom_sub_;
  ros::Subscriber cloud_sub_;
  ros::SteadyTimer tf_poll_timer_;
  std::mutex stats_mutex_;  // guards the diagnostics figures below
  std::size_t last_points_in_ = 0;
  std::size_t last_points_out_ = 0;
  double total_ms_ = 0.0;
  double max_ms_ = 0.0;
  std::size_t processed_ = 0;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<PreprocessorConfig>> reconfigure_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::PreprocessorNodelet, nodelet::Nodelet)
