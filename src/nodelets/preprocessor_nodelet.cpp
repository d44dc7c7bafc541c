// Preprocessor: velodyne_points + odometry -> keyframes. Checks each cloud, lets it wait until it
// can be placed (ScanPlacement: tf, odometry or lidar odometry, which it then broadcasts on tf),
// hands it to core::preprocess::PreprocessorStage, which decides keyframes and filters them, and
// publishes them zero-copy.
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/core/preprocess/preprocessor_stage.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/reconfigure_tables.h"
#include "ccir_mapping/ros/scan_placement.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::preprocess::PreprocessorStage;
using sensor_msgs::PointCloud2;

class PreprocessorNodelet final : public PipelineNodelet {
 private:
  void onInit() override {
    if (!loadSettings(settings_)) return;
    ros::NodeHandle& nh = getNodeHandle();
    stage_ = std::make_unique<PreprocessorStage>(settings_.core);
    const auto& save = settings_.save;
    if (!openJournal(save.resume, [&] {
          if (const auto first = stage_->keepIdJournal(save.dir, save.resume))
            NODELET_INFO("resuming: keyframe ids from %lu on", static_cast<unsigned long>(*first));
        })) {
      return stage_.reset();
    }
    placement_ = std::make_unique<ScanPlacement>(settings_, nh.resolveName(topics::kOdometry));
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(placement_->tf(), nh);
    if (settings_.odom_source == "lidar") tf_broadcaster_.emplace();
    advertise<Keyframe>(topics::kKeyframes, topics::kKeyframeQueueSize);
    if (settings_.odom_source == "topic")
      subscribe(topics::kOdometry, 100, &PreprocessorNodelet::onOdometry);
    subscribe(topics::kVelodynePoints, settings_.scan_queue_size, &PreprocessorNodelet::onCloud);
    if (settings_.odom_source == "tf") {
      // tf arrives on the listener's own thread: look again for scans it can now place.
      // (tf2_ros::MessageFilter would wait too, but stalled scans in this pipeline's tests.)
      tf_poll_timer_ = nh.createSteadyTimer(ros::WallDuration(0.02),
                                            [this](const auto&) { place(placement_->release()); });
    }
    serveReconfigure(ros_params::preprocessorReconfigure(), settings_.core,
                     [this](const auto& params) { stage_->setParams(params); });
  }

  void onOdometry(const nav_msgs::Odometry& msg) {
    if (const auto refusal = placement_->addOdometry(msg)) {
      countDropped("odom", refusal->problem);
      return warnPerKind("odometry " + refusal->problem, "dropping odometry at %.3f: %s%s%s",
                         msg.header.stamp.toSec(), refusal->problem.c_str(),
                         refusal->detail.empty() ? "" : ": ", refusal->detail.c_str());
    }
    place(placement_->release());
  }

  void onCloud(const PointCloud2::ConstPtr& msg) {
    measured("scans", [&] {
      conversions::CloudFields fields;
      if (const auto error = conversions::checkCloud(*msg, &fields)) {
        return dropScan(*msg, {"malformed", "malformed: " + *error});
      }
      if (const auto missing = conversions::missingVelodyneFields(fields); !missing.empty()) {
        NODELET_WARN_THROTTLE(60.0,
                              "clouds on %s lack the field(s) %s of the Velodyne driver's layout "
                              "(x y z intensity ring time); keyframes are made from what is there",
                              getNodeHandle().resolveName(topics::kVelodynePoints).c_str(),
                              missing.c_str());
      }
      const auto arrival = stage_->arrive(conversions::toStamp(msg->header.stamp),
                                          std::size_t{msg->width} * msg->height);
      if (!arrival.accepted) return dropScan(*msg, arrival.notices.front());
      for (const auto& notice : arrival.notices)
        warnPerKind(notice.kind, "%s", notice.text.c_str());
      place(placement_->wait(msg));
    });
  }

  /// Scans placed go on to the stage; those given up are dropped.
  void place(const std::vector<ScanPlacement::Placement>& placements) {
    for (const auto& placement : placements) {
      if (!placement.pose) {
        dropScan(*placement.cloud, {"cannot place it", placement.why});
        continue;
      }
      if (placement.notice) {
        count(placement.notice->kind);
        warnPerKind(placement.notice->kind, "%s", placement.notice->text.c_str());
      }
      if (placement.odometry_tf) tf_broadcaster_->sendTransform(*placement.odometry_tf);
      const PointCloud2& msg = *placement.cloud;
      conversions::toPcl(msg, &scan_);
      const auto result =
          stage_->process(conversions::toStamp(msg.header.stamp), *placement.pose, scan_);
      if (result.dropped())
        countDropped("scans", result.notices.empty() ? "" : result.notices.back().kind);
      for (const auto& notice : result.notices) {
        warnPerKind(notice.kind, "%s cloud at %.3f: %s",
                    result.dropped() ? "dropping" : "about the", msg.header.stamp.toSec(),
                    notice.text.c_str());
      }
      if (result.outcome != PreprocessorStage::Outcome::kKeyframe) continue;
      publish(topics::kKeyframes,
              boost::make_shared<const Keyframe>(conversions::toKeyframeMsg(
                  msg.header, settings_.frames.robot_name, settings_.frames.odom_frame,
                  *placement.pose, result.decision, *result.cloud)));
    }
  }

  void dropScan(const PointCloud2& cloud, const core::Notice& why) {
    countDropped("scans", why.kind);
    warnPerKind(why.kind, "dropping cloud at %.3f in frame '%s': %s", cloud.header.stamp.toSec(),
                cloud.header.frame_id.c_str(), why.text.c_str());
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    if (!stage_) return;
    const auto& totals = stage_->totals();
    status.add("missed scans (gaps in stamps)", totals.missed_scans);
    status.add("keyframe points in (last)", totals.last_points_in);
    status.add("keyframe points out (last)", totals.last_points_out);
    status.addf("ms per keyframe (mean)", "%.1f", totals.meanFilterMs());
    status.addf("ms per keyframe (max)", "%.1f", totals.max_filter_ms);
  }

  ros_params::PreprocessorSettings settings_;
  std::unique_ptr<PreprocessorStage> stage_;
  std::unique_ptr<ScanPlacement> placement_;  // with the scans waiting to be placed
  PreprocessorStage::InputCloud scan_;        // conversion buffer, reused scan after scan
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::optional<tf2_ros::TransformBroadcaster> tf_broadcaster_;  // odom_source "lidar"
  ros::SteadyTimer tf_poll_timer_;
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::PreprocessorNodelet, nodelet::Nodelet)
