// One robot's back end: its keyframes and loop closures as one robust pose graph. Per teammate,
// the EM over inter-robot loop closures decides whether the transform between their frames is
// known; once it is, the teammate joins the graph (team_graph): its known keyframes become nodes,
// chained by odometry edges from its poses, and the inter-robot closures with it become switchable
// constraints like intra-robot ones. Closures between two teammates (found by one of them and
// shared) enter too once both are in the graph, so that each robot's graph holds the whole
// team's (the distributed formulation of Dong et al., ICRA 2015). Two filters in series: a
// closure enters the graph when the EM of its link (this robot and a teammate, or the two
// teammates) counts it an inlier (or the graph's switches kept it before), and the switches then
// judge it against everything else in the graph.
//
//   own:       o---o---o---o---o---o---o---o        o own keyframe, --- odometry
//                  :               :                 : inter-robot loop closure (switchable)
//   teammate:      x---x---x---x---x---x             x teammate keyframe, placed by the graph
//                      :       :
//   teammate 2:        y---y---y---y                 y another's, held to x by x's closures
//
// The teammate's transform is the graph's gauge of its part: the EM's initialises its nodes, and
// after each solve the transform is re-fitted (x y z yaw) between the teammate's own poses and
// their optimised ones, so every accepted closure refines it.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ccir_mapping/core/alignment/frame_alignment.h"
#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/backend/link_gate.h"
#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/common/tum_trajectory.h"
#include "ccir_mapping/core/pose_graph/loop_closure.h"
#include "ccir_mapping/core/pose_graph/pose_graph_optimizer.h"

namespace ccir_mapping::core::backend {

struct TeamEstimate {
  std::string peer;
  /// The EM's decision and inliers; once the teammate is in the graph, alignment.transform is
  /// the graph's (refined) transform.
  alignment::AlignmentResult alignment;
  int candidates = 0;
  /// The teammate's keyframes are optimised in this robot's graph.
  bool in_graph = false;
};

/// A teammate's keyframes in the graph: ids and optimised poses in this robot's map frame.
struct PeerKeyframes {
  std::string robot;
  std::vector<KeyframeId> ids;
  std::vector<Pose3> poses;
};

/// A loop closure to draw: its two keyframes' positions in the map frame.
struct LoopLine {
  Eigen::Vector3d from = Eigen::Vector3d::Zero();
  Eigen::Vector3d to = Eigen::Vector3d::Zero();
  /// Kept by the robust optimiser (an inter-robot one of a teammate not in the graph: an
  /// inlier of the EM, the teammate's keyframe placed with its transform).
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
  /// Teammates in the graph, in name order.
  std::vector<PeerKeyframes> peer_keyframes;
  std::vector<LoopLine> loop_lines;
  /// Intra-robot closures and those the switches turned off; inter-robot closures with joined
  /// teammates and those the gate or the switches turned away.
  struct LoopCounts {
    int intra = 0, intra_rejected = 0, inter = 0, inter_rejected = 0;
  } loops;
  /// What this optimisation decided that a user should hear of (a teammate joined, an EM
  /// result disagreeing with the graph and how it was resolved).
  std::vector<Notice> notices;
  double solve_s = 0.0;
  /// What this optimize() solved: nothing (new keyframes placed by odometry), the newest
  /// keyframes of each robot (solve_window_keyframes), or the whole graph.
  enum class Solve { kNone, kWindow, kFull } solved = Solve::kNone;
  /// Variable poses of that solve.
  int solved_poses = 0;
  /// A full solve: how far it moved the farthest pose from where the windowed solves since the
  /// last full one had left it (m), the price of the window.
  double full_correction_m = 0.0;
  /// The optimisation used all of max_solve_time_s: its result may be short of the optimum.
  bool cut_short = false;

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
  /// Intra-robot (own), or inter-robot: with this robot, or between two teammates (found by one
  /// of them and shared); kept until both keyframes are in the graph. False for a teammate's own
  /// closure (never shared), an invalid pose or covariance, or one knows() already.
  bool addLoopClosure(const pose_graph::LoopClosureData& loop);
  /// Whether a closure between the same two keyframes (either direction) was added: both robots
  /// of a pair may find and share it, and it must count once.
  bool knows(const pose_graph::LoopClosureData& loop) const;

  /// Places what arrived and, when a loop closure (or a keyframe one refers to) arrived since the
  /// last call, re-estimates the team transforms and solves the graph, within max_solve_time_s
  /// (the EM gets at most kEmTimeShare of it, split between the links; the solve the rest).
  /// Without one, new keyframes are only placed by odometry. A solve is windowed
  /// (solve_window_keyframes) or full (full_solve_period_s, see BackendParams). A teammate whose
  /// EM transform is found joins the graph (and is optimised at once). Once joined, a later EM
  /// transform that disagrees with the graph's is judged by judgeDisagreement
  /// (team_disagreement.h): the graph's is kept, or the teammate's part is placed again from the
  /// EM transform and re-optimised. Either way a notice says which.
  BackendSnapshot optimize();
  static constexpr double kEmTimeShare = 0.4;

  /// The whole graph of the last optimisation for inspection (writeG2o): own and teammates'
  /// keyframes named by VertexKey (the robots lettered 'a', 'b', ... in name order, listed in
  /// `robots`; the index is the keyframe id), and each edge's switch value (1 for odometry).
  pose_graph::PoseGraph exportGraph(std::vector<double>* switch_values,
                                    std::vector<std::string>* robots) const;
  /// exportGraph() written as g2o (switchable loop closures with their values), preceded by a
  /// comment naming each robot's letter. Throws std::runtime_error when it cannot write.
  void saveG2o(const std::string& path) const;
  /// This robot's keyframes (stamps, poses): in the map frame as of the last optimisation (the
  /// newer ones continued by odometry), and their odometry poses in the odometry frame.
  TumTrajectory trajectory() const;
  TumTrajectory odometry() const;
  /// Writes DIR/team_graph.g2o (saveG2o), DIR/trajectory.tum and DIR/odometry.tum (TUM format),
  /// creating DIR, and returns their paths. Throws std::runtime_error naming what it could not
  /// write.
  std::vector<std::string> save(const std::string& dir) const;

  /// Marginal covariances of the given own keyframes at the last optimisation (the whole graph,
  /// teammates' parts and every accepted closure included), computed on the graph thinned to
  /// them and every varianceStride()-th pose (pose_graph::thinChains).
  std::optional<std::vector<Eigen::MatrixXd>> covariances(const std::vector<KeyframeId>& ids) const;
  /// CCIR's u_k of the given keyframes (in trajectory order): the geometric mean of the
  /// eigenvalues of each one's marginal position covariance, m^2 (monotone in their product, the
  /// thesis's u, and still a variance: the product of three ~1e-3 m^2 variances underflows the
  /// scale of everything else). Marginals at every varianceStride()-th and the last; the
  /// others carry the one before them plus their odometry step's position variance.
  std::optional<std::vector<double>> positionVariances(const std::vector<KeyframeId>& ids) const;
  /// Every how many poses the marginals' thinned graph keeps one: kVarianceAnchorEvery, or
  /// more on a graph of over kVarianceNodes * kVarianceAnchorEvery poses, so that their cost
  /// stays flat.
  std::size_t varianceStride() const;
  static constexpr std::size_t kVarianceAnchorEvery = 10;
  static constexpr std::size_t kVarianceNodes = 300;

 private:
  std::string robot_;
  backend::BackendParams params_;
  pose_graph::PoseGraphOptimizer optimizer_;
  pose_graph::PoseGraph graph_;  // this robot's keyframes
  std::vector<KeyframeId> ids_;
  std::vector<Stamp> stamps_;
  std::vector<Pose3> odom_poses_;
  pose_graph::OdometryUncertainty odom_uncertainty_;
  std::vector<pose_graph::Covariance6> odom_covariances_;  // of odom_poses_, world frame
  std::map<KeyframeId, int> index_;
  std::map<std::string, std::map<KeyframeId, Pose3>> peers_;
  /// Teammates in the graph: their transform and the optimised poses of their keyframes.
  struct Joined {
    Pose3 transform = Pose3::Identity();
    std::map<KeyframeId, Pose3> poses;
    std::set<KeyframeId> unsolved;  // placed by odometry since the last solve
  };
  std::map<std::string, Joined> joined_;
  std::vector<pose_graph::LoopClosureData> loops_;  // all of them; resolved at each optimisation
  static LoopKey keyOf(const pose_graph::LoopClosureData& loop);
  std::set<LoopKey> loop_keys_;
  std::set<KeyframeOf> loop_ends_;  // the keyframes of loops_
  /// What each loop in the graph ended its last solve with.
  struct LoopState {
    double switch_value = 1.0;
    double weight = 1.0;
    bool inlier = true;
  };
  std::map<LoopKey, LoopState> loop_states_;
  /// A loop closure, or a keyframe one refers to, arrived since the last solve (or that solve
  /// was cut short); full_due_: the next solve must be a full one.
  bool solve_due_ = false;
  bool full_due_ = true;
  bool windowed_since_full_ = false;
  std::optional<Stamp> last_full_;
  std::size_t solved_own_ = 0;  // own keyframes the last solve had (newer: placed by odometry)
  /// The whole graph at the current estimate: own keyframes first, then each joined teammate's
  /// in name and id order; the loops gated in, and those gated out.
  struct Assembled {
    pose_graph::PoseGraph graph;
    std::size_t own_count = 0;
    std::vector<KeyframeOf> nodes;                // the keyframe of each node
    std::vector<LoopKey> edge_keys;               // of each edge (loops only)
    std::vector<std::optional<Link>> edge_links;  // of each inter-robot loop
    std::vector<std::pair<int, int>> gated_out;
    BackendSnapshot::LoopCounts loops;  // intra and inter; rejected ones counted by keep()
  };
  Assembled assemble() const;
  /// Solves `a` (its poses updated) windowed or whole, keeps the loops' states; returns the
  /// variable poses.
  int solve(Assembled& a, bool full, double max_time_s, BackendSnapshot& snapshot);
  /// What a windowed solve of `a` frees: per robot, the newest solve_window_keyframes keyframes
  /// and those placed since the last solve (never the first node, the gauge). The rest of this
  /// robot's is held; the rest of each teammate's moves in rigid blocks of consecutive keyframes,
  /// each by one pose, its newest keyframe's (`block`: that node for each keyframe of a block,
  /// else -1). Why not held: a teammate's older keyframes must follow this robot's corrections,
  /// or its loops pull the window towards a stale placement. A new own loop with neither
  /// keyframe free, or that the estimate misses by more than revisit_loop_error_m, frees every
  /// own keyframe back to its older end.
  struct Window {
    std::vector<bool> variable;
    std::vector<int> block;
  };
  Window window(const Assembled& a) const;
  /// Each link's EM (or re-check) within kEmTimeShare of max_solve_time_s: the gate admits
  /// its inliers, a teammate whose transform is found joins, a disagreement is resolved (see
  /// optimize()); the team estimates go into the snapshot, the EM's closures of teammates kept
  /// out of the graph into em_lines.
  void judgeLinks(BackendSnapshot& snapshot, std::vector<LoopLine>& em_lines,
                  const std::function<double()>& elapsed_s);
  /// New keyframes of joined teammates placed: each continues from the previous one's pose by
  /// its odometry step (the first one by the transform).
  void placeJoinedKeyframes();
  /// The optimised poses of `a` kept, its loops reported in the snapshot, the graph kept for
  /// inspection.
  void keep(Assembled&& a, BackendSnapshot& snapshot);
  /// What the last EM pass said (reused while no loop closure arrives).
  std::vector<TeamEstimate> last_team_;
  std::vector<LoopLine> last_em_lines_;
  std::vector<double> last_weights_;
  pose_graph::PoseGraph last_graph_;    // the whole graph of the last optimisation
  std::size_t last_own_count_ = 0;      // own keyframes (its first nodes) in last_graph_
  std::vector<KeyframeOf> last_nodes_;  // the keyframe of each node

  /// Index of own keyframe `id` in the graph, or -1.
  int ownIndex(KeyframeId id) const;
  /// An inter-robot closure along its link: keyframe `first` of link.first, keyframe `second` of
  /// link.second, and the second's pose in the first's frame.
  struct Oriented {
    Link link;
    KeyframeId first;
    KeyframeId second;
    Pose3 relative;
  };
  /// nullopt for a closure within one robot.
  std::optional<Oriented> oriented(const pose_graph::LoopClosureData& loop) const;
  /// The EM's candidates along one link, and the closure each one is.
  struct Candidates {
    std::vector<alignment::AlignmentCandidate> list;
    std::vector<LoopKey> keys;
  };
  /// Per link: own keyframes at their optimised poses, teammates' at their own, each with its
  /// drift.
  std::map<Link, Candidates> candidates() const;
  /// Covariance of each of the teammate's poses from its odometry (this robot's noise model).
  std::map<KeyframeId, pose_graph::Covariance6> peerDrift(const std::string& peer) const;
  /// The teammate's transform fitted (x y z yaw) from its own poses to its optimised ones.
  Pose3 refinedTransform(const std::string& peer) const;
  LinkGate gate_;
};

}  // namespace ccir_mapping::core::backend
