// One robot's back end: its keyframes and intra-robot loop closures as a robust pose graph, and
// per teammate the transform between their frames from inter-robot loop closures (EM).
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/backend/loop_closure.h"
#include "ccir_mapping/core/backend/pose_graph_optimizer.h"

namespace ccir_mapping::core::team {

struct TeamEstimate {
  std::string peer;
  /// The peer's frame in this robot's map frame (when found).
  alignment::AlignmentResult alignment;
  int candidates = 0;
};

/// A loop closure to draw: its two keyframes' positions in the map frame.
struct LoopLine {
  Eigen::Vector3d from = Eigen::Vector3d::Zero();
  Eigen::Vector3d to = Eigen::Vector3d::Zero();
  /// Intra-robot: kept by the robust optimiser; inter-robot lines are the team transform's
  /// inliers (the teammate's keyframe placed with it).
  bool accepted = false;
  bool inter_robot = false;
};

struct BackendSnapshot {
  /// This robot's keyframes: id, stamp and optimised pose in the map frame, in id order.
  std::vector<KeyframeId> ids;
  std::vector<Stamp> stamps;
  std::vector<Pose3> poses;
  /// The newest keyframe's odometry pose.
  Pose3 latest_odom_pose = Pose3::Identity();
  std::vector<TeamEstimate> team;
  std::vector<LoopLine> loop_lines;
  int intra_loops = 0;
  int intra_loops_rejected = 0;
  double solve_s = 0.0;

  /// The odometry frame in the map frame: the correction the newest optimisation makes to
  /// odometry (identity while there is no keyframe).
  Pose3 mapFromOdom() const {
    return poses.empty() ? Pose3::Identity() : Pose3(poses.back() * latest_odom_pose.inverse());
  }
};

class TeamGraph {
 public:
  /// Throws std::invalid_argument when params.validate() reports errors.
  TeamGraph(std::string robot, const backend::BackendParams& params);

  const std::string& robot() const { return robot_; }

  /// This robot's keyframes, in id order (ids increasing), with their odometry poses.
  /// Returns false (and changes nothing) for a non-increasing id or an invalid pose.
  bool addKeyframe(KeyframeId id, Stamp stamp, const Pose3& odom_pose);
  /// A teammate's keyframe, with its pose in the teammate's frame.
  bool addPeerKeyframe(const std::string& robot, KeyframeId id, const Pose3& pose);
  /// Intra- or inter-robot; kept until both keyframes are known. False when it concerns neither
  /// this robot nor is otherwise usable (both keyframes a teammate's, invalid pose), or when
  /// knows() it.
  bool addLoopClosure(const backend::LoopClosureData& loop);
  /// Whether a closure between the same two keyframes (either direction) was added: both robots
  /// of a pair may find and share it, and it must count once.
  bool knows(const backend::LoopClosureData& loop) const;

  /// Optimises the graph and re-estimates every team transform.
  BackendSnapshot optimize();

  /// Marginal covariances of the given keyframes at the last optimisation (pose uncertainty).
  std::optional<std::vector<Eigen::MatrixXd>> covariances(const std::vector<KeyframeId>& ids) const;
  /// CCIR's u_k of the given keyframes: the geometric mean of the eigenvalues of each one's
  /// marginal position covariance, m^2 (monotone in their product, the thesis's u, and still a
  /// variance: the product of three ~1e-3 m^2 variances underflows the scale of everything else).
  std::optional<std::vector<double>> positionVariances(const std::vector<KeyframeId>& ids) const;

 private:
  std::string robot_;
  backend::BackendParams params_;
  backend::PoseGraphOptimizer optimizer_;
  backend::PoseGraph graph_;  // this robot's keyframes
  std::vector<KeyframeId> ids_;
  std::vector<Stamp> stamps_;
  std::vector<Pose3> odom_poses_;
  backend::OdometryUncertainty odom_uncertainty_;
  std::vector<backend::Covariance6> odom_covariances_;  // of odom_poses_, world frame
  std::map<KeyframeId, int> index_;
  std::map<std::string, std::map<KeyframeId, Pose3>> peers_;
  std::vector<backend::LoopClosureData> loops_;  // all of them; resolved at each optimisation
  /// The two keyframes of each of loops_, in a fixed order.
  using KeyframeOf = std::pair<std::string, KeyframeId>;
  using LoopKey = std::pair<KeyframeOf, KeyframeOf>;
  static LoopKey keyOf(const backend::LoopClosureData& loop);
  std::set<LoopKey> loop_keys_;
  std::vector<double> last_weights_;
  backend::PoseGraph last_graph_;  // graph_ with the loops of the last optimisation
};

}  // namespace ccir_mapping::core::team
