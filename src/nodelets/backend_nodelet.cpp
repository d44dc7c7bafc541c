// Backend: keyframes + loop closures -> optimised trajectory, map -> odom and team transforms on
// tf, TeamTransform messages, pose uncertainty. Thin: callbacks only queue their input; a worker
// thread owns the core TeamGraph and optimises at optimize_period_s (and as soon as a loop closure
// arrives), so no solve ever holds a manager thread.
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <variant>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

#include "ccir_mapping/Keyframe.h"
#include "ccir_mapping/KeyframeUncertainty.h"
#include "ccir_mapping/LoopClosure.h"
#include "ccir_mapping/TeamTransform.h"
#include "ccir_mapping/core/backend/team_graph.h"
#include "ccir_mapping/ros/conversions.h"
#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/topics.h"
#include "pipeline_nodelet.h"

namespace ccir_mapping {

using core::backend::TeamGraph;

class BackendNodelet final : public PipelineNodelet {
 public:
  ~BackendNodelet() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

 private:
  struct OwnKeyframe {
    core::KeyframeId id;
    core::Stamp stamp;
    core::Pose3 pose;
  };
  struct PeerKeyframe {
    std::string robot;
    core::KeyframeId id;
    core::Pose3 pose;
  };
  using Input = std::variant<OwnKeyframe, PeerKeyframe, core::backend::LoopClosureData>;

  void onInit() override {
    if (!loadSettings(settings_)) return;
    graph_ = std::make_unique<TeamGraph>(settings_.frames.robot_name, settings_.core);
    ros::NodeHandle& nh = getNodeHandle();
    trajectory_pub_ = nh.advertise<nav_msgs::Path>(topics::kTrajectory, 1, /*latch=*/true);
    team_pub_ = nh.advertise<TeamTransform>(topics::kTeamTransforms, topics::kMessageQueueSize);
    uncertainty_pub_ = nh.advertise<KeyframeUncertainty>(topics::kKeyframeUncertainty, 1);
    loop_marker_pub_ =
        nh.advertise<visualization_msgs::MarkerArray>(topics::kLoopClosureMarkers, 1);
    keyframe_sub_ = nh.subscribe(topics::kKeyframes, topics::kKeyframeQueueSize,
                                 &BackendNodelet::onKeyframe, this);
    peer_sub_ = nh.subscribe(topics::kTeammateScans, topics::kKeyframeQueueSize,
                             &BackendNodelet::onPeerKeyframe, this);
    loop_sub_ = nh.subscribe(topics::kLoopClosures, topics::kLoopClosureQueueSize,
                             &BackendNodelet::onLoopClosure, this);
    // Inter-robot closures go to the teammates too: each robot verifies only the scans it
    // received, so without them a pair's two robots each see part of its closures.
    outbox_loop_pub_ =
        nh.advertise<LoopClosure>(topics::kOutboxLoopClosures, topics::kLoopClosureQueueSize);
    inbox_loop_sub_ = nh.subscribe(topics::kInboxLoopClosures, topics::kLoopClosureQueueSize,
                                   &BackendNodelet::onTeammateLoopClosure, this);
    worker_ = std::thread([this] { run(); });
    createPeriodicTimer(settings_.core.optimize_period_s, [this] {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        due_ = true;
      }
      wake_.notify_one();
    });
  }

  void queue(Input input, bool urgent) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      inputs_.push_back(std::move(input));
      due_ = due_ || urgent;
    }
    if (urgent) wake_.notify_one();
  }

  void onKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in keyframes");
    const auto pose = conversions::toPose(keyframe->odom_pose);
    if (!pose || keyframe->robot != settings_.frames.robot_name) {
      NODELET_WARN_THROTTLE(5.0, "dropping keyframe %lu of '%s': %s",
                            static_cast<unsigned long>(keyframe->id), keyframe->robot.c_str(),
                            pose ? "not this robot's" : "its pose is not finite");
      count("dropped keyframes");
      return;
    }
    queue(OwnKeyframe{keyframe->id, conversions::toStamp(keyframe->header.stamp), *pose}, false);
  }

  void onPeerKeyframe(const Keyframe::ConstPtr& keyframe) {
    count("in teammate_scans");
    const auto pose = conversions::toPose(keyframe->odom_pose);
    if (!pose || keyframe->robot == settings_.frames.robot_name || keyframe->robot.empty()) {
      NODELET_WARN_THROTTLE(5.0, "dropping a teammate's keyframe from '%s': %s",
                            keyframe->robot.c_str(),
                            pose ? "not a teammate's" : "its pose is not finite");
      count("dropped teammate_scans");
      return;
    }
    queue(PeerKeyframe{keyframe->robot, keyframe->id, *pose}, false);
  }

  /// The closure in the core's terms, or nullopt (warned, counted in `flow`).
  std::optional<core::backend::LoopClosureData> toLoop(const LoopClosure& msg, const char* flow) {
    const auto pose = conversions::toPose(msg.relative_pose);
    core::backend::LoopClosureData loop;
    loop.robot_from = msg.robot_from;
    loop.keyframe_from = msg.keyframe_from;
    loop.robot_to = msg.robot_to;
    loop.keyframe_to = msg.keyframe_to;
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) loop.covariance(r, c) = msg.covariance[r * 6 + c];
    }
    const Eigen::LLT<core::alignment::Matrix6> llt(loop.covariance);
    // LLT does not notice NaN entries.
    const bool covariance_ok = loop.covariance.allFinite() && llt.info() == Eigen::Success;
    if (!pose || !covariance_ok) {
      NODELET_WARN_THROTTLE(
          5.0, "dropping loop closure %s/%lu -> %s/%lu from %s: %s", msg.robot_from.c_str(),
          static_cast<unsigned long>(msg.keyframe_from), msg.robot_to.c_str(),
          static_cast<unsigned long>(msg.keyframe_to), flow,
          !pose ? "relative pose not finite" : "covariance not finite and positive definite");
      count(std::string("dropped ") + flow);
      return std::nullopt;
    }
    loop.relative = *pose;
    return loop;
  }

  void onLoopClosure(const LoopClosure::ConstPtr& msg) {
    count("in loop_closures");
    const std::string& self = settings_.frames.robot_name;
    if (msg->robot_from != self && msg->robot_to != self) {
      NODELET_WARN_THROTTLE(5.0, "dropping loop closure %s -> %s: it does not involve this robot",
                            msg->robot_from.c_str(), msg->robot_to.c_str());
      count("dropped loop_closures");
      return;
    }
    const auto loop = toLoop(*msg, "loop_closures");
    if (!loop) return;
    queue(*loop, true);
    if (msg->robot_from != msg->robot_to) {
      count("out outbox/loop_closures");
      outbox_loop_pub_.publish(msg);
    }
  }

  /// A closure a teammate found (its keyframe "from", with its odometry pose): used when it
  /// joins this robot, ignored when it is between two others.
  void onTeammateLoopClosure(const LoopClosure::ConstPtr& msg) {
    count("in inbox/loop_closures");
    const std::string& self = settings_.frames.robot_name;
    if (msg->robot_to != self || msg->robot_from == self) {
      count("ignored inbox/loop_closures (not with this robot)");
      return;
    }
    const auto pose_from = conversions::toPose(msg->odom_pose_from);
    const auto loop = toLoop(*msg, "inbox/loop_closures");
    if (!loop) return;
    if (!pose_from || msg->robot_from.empty()) {
      NODELET_WARN_THROTTLE(5.0, "dropping a teammate's loop closure from '%s': %s",
                            msg->robot_from.c_str(),
                            pose_from ? "it names no robot" : "odom_pose_from is not valid");
      count("dropped inbox/loop_closures");
      return;
    }
    queue(PeerKeyframe{msg->robot_from, msg->keyframe_from, *pose_from}, false);
    queue(*loop, true);
  }

  // The worker: owns graph_, optimises when there is something new, at the period's ticks
  // (mission time when replaying) or at once for a loop closure.
  void run() {
    while (true) {
      std::deque<Input> inputs;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || due_; });
        if (stop_) return;
        due_ = false;
        inputs.swap(inputs_);
      }
      if (inputs.empty()) continue;
      publish(measured("optimise", [&] {
        for (const Input& input : inputs) apply(input);
        return graph_->optimize();
      }));
    }
  }

  void apply(const Input& input) {
    if (const auto* own = std::get_if<OwnKeyframe>(&input)) {
      if (!graph_->addKeyframe(own->id, own->stamp, own->pose)) {
        NODELET_WARN_THROTTLE(5.0, "keyframe %lu ignored: ids must increase",
                              static_cast<unsigned long>(own->id));
        count("dropped keyframes");
      }
    } else if (const auto* peer = std::get_if<PeerKeyframe>(&input)) {
      if (!graph_->addPeerKeyframe(peer->robot, peer->id, peer->pose)) {
        NODELET_WARN_THROTTLE(5.0, "teammate keyframe %s/%lu rejected by the graph",
                              peer->robot.c_str(), static_cast<unsigned long>(peer->id));
        count("dropped teammate_scans");
      }
    } else {
      // The callback checked pose, covariance and ownership; the graph also refuses a keyframe
      // looped to itself.
      const auto& loop = std::get<core::backend::LoopClosureData>(input);
      if (graph_->knows(loop)) {
        count("duplicate loop_closures");  // the teammate found it too
      } else if (!graph_->addLoopClosure(loop)) {
        NODELET_WARN_THROTTLE(5.0, "loop closure %s/%lu -> %s/%lu rejected by the graph",
                              loop.robot_from.c_str(),
                              static_cast<unsigned long>(loop.keyframe_from), loop.robot_to.c_str(),
                              static_cast<unsigned long>(loop.keyframe_to));
        count("dropped loop_closures");
      }
    }
  }

  /// Loop closures as lines between their keyframes: kept intra-robot ones green, rejected red,
  /// the team transforms' inter-robot inliers blue.
  void publishLoopMarkers(const core::backend::BackendSnapshot& snapshot, const ros::Time& stamp) {
    auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
    const char* names[] = {"loops kept", "loops rejected", "inter-robot loops"};
    const float colours[][3] = {{0.1F, 0.8F, 0.1F}, {0.9F, 0.1F, 0.1F}, {0.2F, 0.4F, 1.0F}};
    for (int kind = 0; kind < 3; ++kind) {
      visualization_msgs::Marker m;
      m.header.frame_id = settings_.frames.map_frame;
      m.header.stamp = stamp;
      m.ns = names[kind];
      m.type = visualization_msgs::Marker::LINE_LIST;
      m.pose.orientation.w = 1.0;
      m.scale.x = 0.1;
      m.color.r = colours[kind][0];
      m.color.g = colours[kind][1];
      m.color.b = colours[kind][2];
      m.color.a = 1.0F;
      for (const auto& line : snapshot.loop_lines) {
        const int k = line.inter_robot ? 2 : (line.accepted ? 0 : 1);
        if (k != kind) continue;
        m.points.push_back(tf2::toMsg(line.from));
        m.points.push_back(tf2::toMsg(line.to));
      }
      // An empty LINE_LIST is removed rather than drawn.
      m.action =
          m.points.empty() ? visualization_msgs::Marker::DELETE : visualization_msgs::Marker::ADD;
      markers->markers.push_back(m);
    }
    loop_marker_pub_.publish(markers);
  }

  void publish(const core::backend::BackendSnapshot& snapshot) {
    if (snapshot.poses.empty()) return;
    const ros::Time stamp = conversions::toRosTime(snapshot.stamps.back());
    auto path = boost::make_shared<nav_msgs::Path>();
    path->header.frame_id = settings_.frames.map_frame;
    path->header.stamp = stamp;
    for (std::size_t i = 0; i < snapshot.poses.size(); ++i) {
      geometry_msgs::PoseStamped pose;
      pose.header.frame_id = settings_.frames.map_frame;
      pose.header.stamp = conversions::toRosTime(snapshot.stamps[i]);
      pose.pose = conversions::toPoseMsg(snapshot.poses[i]);
      path->poses.push_back(pose);
    }
    count("out trajectory");
    trajectory_pub_.publish(path);
    if (loop_marker_pub_.getNumSubscribers() > 0) publishLoopMarkers(snapshot, stamp);

    std::vector<geometry_msgs::TransformStamped> transforms;
    // A re-optimisation without a new keyframe (a teammate's scan, a loop closure) must still
    // reach tf: tf2 ignores a transform repeated at a stamp it has, so the stamp moves on by 1 us.
    const ros::Time tf_stamp = std::max(stamp, last_tf_stamp_ + ros::Duration(1e-6));
    if (settings_.publish_tf) {
      geometry_msgs::TransformStamped map_to_odom;
      map_to_odom.header.stamp = tf_stamp;
      map_to_odom.header.frame_id = settings_.frames.map_frame;
      map_to_odom.child_frame_id = settings_.frames.odom_frame;
      map_to_odom.transform =
          conversions::toTransformMsg(snapshot.poses.back() * snapshot.latest_odom_pose.inverse());
      transforms.push_back(map_to_odom);
    }
    for (const auto& estimate : snapshot.team) {
      const auto& a = estimate.alignment;
      auto msg = boost::make_shared<TeamTransform>();
      msg->header.stamp = stamp;
      msg->header.frame_id = settings_.frames.map_frame;
      msg->peer = estimate.peer;
      msg->child_frame_id = estimate.peer + "/map";
      msg->valid = a.found;
      msg->transform = conversions::toTransformMsg(a.transform);
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < 6; ++c) msg->covariance[r * 6 + c] = a.covariance(r, c);
      }
      msg->inliers = static_cast<std::uint32_t>(a.inlier_count);
      msg->candidates = static_cast<std::uint32_t>(estimate.candidates);
      msg->margin = a.runner_up_inliers > 0 ? double(a.inlier_count) / a.runner_up_inliers
                                            : double(a.inlier_count);
      count("out team_transforms");
      team_pub_.publish(msg);
      if (a.found && settings_.publish_tf) {
        geometry_msgs::TransformStamped team;
        team.header = msg->header;
        team.header.stamp = tf_stamp;
        team.child_frame_id = msg->child_frame_id;
        team.transform = msg->transform;
        transforms.push_back(team);
      }
      if (!a.found)
        NODELET_DEBUG("no transform to %s yet: %s", estimate.peer.c_str(), a.reason.c_str());
    }
    if (!transforms.empty()) {
      tf_broadcaster_.sendTransform(transforms);
      last_tf_stamp_ = tf_stamp;
    }

    if (uncertainty_pub_.getNumSubscribers() > 0) {  // the Broker's u_k (CCIR)
      const auto variances =
          measured("uncertainty", [&] { return graph_->positionVariances(snapshot.ids); });
      if (variances) {
        auto msg = boost::make_shared<KeyframeUncertainty>();
        msg->header = path->header;
        msg->robot = settings_.frames.robot_name;
        msg->keyframe_ids.assign(snapshot.ids.begin(), snapshot.ids.end());
        msg->position_variance_m2 = *variances;
        count("out keyframe_uncertainty");
        uncertainty_pub_.publish(msg);
      }
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    last_solve_s_ = snapshot.solve_s;
    intra_loops_ = snapshot.intra_loops;
    intra_rejected_ = snapshot.intra_loops_rejected;
  }

  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) override {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    status.addf("last optimisation s", "%.3f", last_solve_s_);
    status.add("intra-robot loops", intra_loops_);
    status.add("intra-robot loops rejected", intra_rejected_);
  }

  ros_params::BackendSettings settings_;
  std::unique_ptr<TeamGraph> graph_;  // the worker's
  std::mutex mutex_;                  // guards what callbacks hand to the worker
  std::condition_variable wake_;
  std::deque<Input> inputs_;
  bool due_ = false;  // an optimisation is due: a period tick or a loop closure
  bool stop_ = false;
  std::thread worker_;
  std::mutex stats_mutex_;
  double last_solve_s_ = 0.0;
  int intra_loops_ = 0;
  int intra_rejected_ = 0;
  ros::Publisher trajectory_pub_;
  ros::Publisher loop_marker_pub_;
  ros::Publisher team_pub_;
  ros::Publisher uncertainty_pub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber peer_sub_;
  ros::Subscriber loop_sub_;
  ros::Publisher outbox_loop_pub_;
  ros::Subscriber inbox_loop_sub_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Time last_tf_stamp_;  // of the last transforms sent (worker thread only)
};

}  // namespace ccir_mapping

PLUGINLIB_EXPORT_CLASS(ccir_mapping::BackendNodelet, nodelet::Nodelet)
