#include "ccir_mapping/core/team/team_graph.h"

#include <chrono>
#include <stdexcept>

#include <Eigen/Geometry>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core::team {

using backend::BackendParams;
using backend::Covariance6;
using backend::inBodyFrame;
using backend::LoopClosureData;
using backend::OdometryUncertainty;
using backend::OptimizationResult;
using backend::OptimizerParams;
using backend::PoseGraph;
using backend::PoseGraphEdge;
using backend::stepCovariance;

namespace {

OptimizerParams optimizerParams(const BackendParams& p) {
  OptimizerParams o;
  o.kernel = p.robust_kernel;
  o.switch_prior_sigma = p.switch_prior_sigma;
  o.max_iterations = p.max_iterations;
  o.max_solve_time_s = p.max_solve_time_s;
  return o;
}

}  // namespace

TeamGraph::TeamGraph(std::string robot, const BackendParams& params)
    : robot_(std::move(robot)),
      params_(validated(params)),
      optimizer_(optimizerParams(params)),
      odom_uncertainty_(params.odometry) {
  graph_.dimension = 3;
}

bool TeamGraph::addKeyframe(KeyframeId id, Stamp stamp, const Pose3& odom_pose) {
  if (!isValidPose(odom_pose) || (!ids_.empty() && id <= ids_.back())) return false;
  if (ids_.empty()) {
    graph_.poses.push_back(odom_pose);  // the map frame starts at the odometry frame
  } else {
    const Pose3 step = odom_poses_.back().inverse() * odom_pose;
    graph_.poses.push_back(graph_.poses.back() * step);  // continue from the optimised pose
    PoseGraphEdge edge;
    edge.from = static_cast<int>(ids_.size()) - 1;
    edge.to = static_cast<int>(ids_.size());
    edge.measurement = step;
    edge.information = stepCovariance(step, params_.odometry).inverse();
    graph_.edges.push_back(edge);
  }
  index_[id] = static_cast<int>(ids_.size());
  ids_.push_back(id);
  stamps_.push_back(stamp);
  odom_poses_.push_back(odom_pose);
  odom_covariances_.push_back(odom_uncertainty_.advance(odom_pose));
  return true;
}

bool TeamGraph::addPeerKeyframe(const std::string& robot, KeyframeId id, const Pose3& pose) {
  if (robot == robot_ || robot.empty() || !isValidPose(pose)) return false;
  peers_[robot][id] = pose;
  return true;
}

bool TeamGraph::addLoopClosure(const LoopClosureData& loop) {
  if (!isValidPose(loop.relative) || !loop.covariance.allFinite()) return false;
  if (loop.robot_from != robot_ && loop.robot_to != robot_) return false;
  if (loop.robot_from == robot_ && loop.robot_to == robot_ &&
      loop.keyframe_from == loop.keyframe_to) {
    return false;
  }
  const Eigen::LLT<Matrix6> llt(loop.covariance);
  if (llt.info() != Eigen::Success || knows(loop)) return false;
  loops_.push_back(loop);
  loop_keys_.insert(keyOf(loop));
  return true;
}

TeamGraph::LoopKey TeamGraph::keyOf(const LoopClosureData& loop) {
  KeyframeOf from{loop.robot_from, loop.keyframe_from};
  KeyframeOf to{loop.robot_to, loop.keyframe_to};
  return from < to ? LoopKey{from, to} : LoopKey{to, from};
}

bool TeamGraph::knows(const LoopClosureData& loop) const { return loop_keys_.count(keyOf(loop)); }

BackendSnapshot TeamGraph::optimize() {
  BackendSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  // The graph: odometry edges (kept in graph_) plus the intra-robot loops whose keyframes exist.
  PoseGraph graph = graph_;
  std::map<std::string, std::vector<alignment::AlignmentCandidate>> candidates;
  for (const auto& loop : loops_) {
    if (loop.robot_from == robot_ && loop.robot_to == robot_) {
      const auto from = index_.find(loop.keyframe_from);
      const auto to = index_.find(loop.keyframe_to);
      if (from == index_.end() || to == index_.end()) continue;
      PoseGraphEdge edge;
      edge.from = from->second;
      edge.to = to->second;
      edge.measurement = loop.relative;
      edge.information = loop.covariance.inverse();
      edge.loop = true;
      graph.edges.push_back(edge);
      ++snapshot.intra_loops;
    }
  }
  if (graph.poses.size() >= 2) {
    const OptimizationResult result = optimizer_.optimize(graph);
    graph_.poses = graph.poses;
    last_weights_ = result.weights;
    last_graph_ = graph;
    for (std::size_t k = 0; k < graph.edges.size(); ++k) {
      const PoseGraphEdge& e = graph.edges[k];
      if (!e.loop) continue;
      snapshot.intra_loops_rejected += !result.inliers[k];
      snapshot.loop_lines.push_back({graph.poses[static_cast<std::size_t>(e.from)].translation(),
                                     graph.poses[static_cast<std::size_t>(e.to)].translation(),
                                     static_cast<bool>(result.inliers[k]), false});
    }
  }

  // Inter-robot loops, oriented from this robot to the peer, against the optimised poses; each
  // with the drift of both keyframes since their robots' starts (the peer's from its keyframes'
  // poses, with this robot's odometry model), so that a true loop seen after long drift still
  // agrees and the least drifted loops weigh most.
  std::map<std::string, std::map<KeyframeId, Covariance6>> peer_covariances;
  for (const auto& [peer, keyframes] : peers_) {
    OdometryUncertainty chain(params_.odometry);
    for (const auto& [id, pose] : keyframes) peer_covariances[peer][id] = chain.advance(pose);
  }
  for (const auto& loop : loops_) {
    const bool outgoing = loop.robot_from == robot_ && loop.robot_to != robot_;
    const bool incoming = loop.robot_to == robot_ && loop.robot_from != robot_;
    if (!outgoing && !incoming) continue;
    const std::string& peer = outgoing ? loop.robot_to : loop.robot_from;
    const KeyframeId mine = outgoing ? loop.keyframe_from : loop.keyframe_to;
    const KeyframeId theirs = outgoing ? loop.keyframe_to : loop.keyframe_from;
    const auto own = index_.find(mine);
    const auto peer_keyframes = peers_.find(peer);
    if (own == index_.end() || peer_keyframes == peers_.end()) continue;
    const auto other = peer_keyframes->second.find(theirs);
    if (other == peer_keyframes->second.end()) continue;
    alignment::AlignmentCandidate c;
    c.pose_a = graph_.poses[static_cast<std::size_t>(own->second)];
    c.pose_b = other->second;
    c.measurement = outgoing ? loop.relative : loop.relative.inverse();
    c.covariance = loop.covariance;  // a first-order approximation for the inverted direction
    const std::size_t i = static_cast<std::size_t>(own->second);
    c.covariance_a = inBodyFrame(odom_covariances_[i], odom_poses_[i].linear());
    c.covariance_b = inBodyFrame(peer_covariances.at(peer).at(theirs),
                                 c.pose_b.linear() * c.measurement.linear().transpose());
    candidates[peer].push_back(c);
  }
  for (const auto& [peer, list] : candidates) {
    alignment::AlignmentParams params;
    params.min_inliers = params_.min_team_inliers;
    params.min_inlier_margin = params_.team_inlier_margin;
    TeamEstimate estimate;
    estimate.peer = peer;
    estimate.candidates = static_cast<int>(list.size());
    estimate.alignment = alignment::estimateFrameTransform(list, params);
    for (std::size_t k = 0; estimate.alignment.found && k < list.size(); ++k) {
      if (!estimate.alignment.inliers[k]) continue;
      snapshot.loop_lines.push_back({list[k].pose_a.translation(),
                                     (estimate.alignment.transform * list[k].pose_b).translation(),
                                     true, true});
    }
    snapshot.team.push_back(estimate);
  }

  snapshot.ids = ids_;
  snapshot.stamps = stamps_;
  snapshot.poses = graph_.poses;
  if (!odom_poses_.empty()) snapshot.latest_odom_pose = odom_poses_.back();
  snapshot.solve_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return snapshot;
}

std::optional<std::vector<Eigen::MatrixXd>> TeamGraph::covariances(
    const std::vector<KeyframeId>& ids) const {
  std::vector<int> indices;
  for (const KeyframeId id : ids) {
    const auto it = index_.find(id);
    if (it == index_.end()) return std::nullopt;
    indices.push_back(it->second);
  }
  // The last optimised graph, loops weighted as the robust kernel left them: a loop the
  // switches accepted shrinks the uncertainty of the keyframes it closes.
  if (last_graph_.poses.size() != graph_.poses.size()) {
    return optimizer_.marginalCovariances(graph_, indices);
  }
  return optimizer_.marginalCovariances(last_graph_, indices, last_weights_);
}

std::optional<std::vector<double>> TeamGraph::positionVariances(
    const std::vector<KeyframeId>& ids) const {
  const auto all = covariances(ids);
  if (!all) return std::nullopt;
  std::vector<double> variances;
  for (const auto& covariance : *all) {
    // The position block leads (x y z, then rotation); the gauge keyframe's is 0.
    const double det = covariance.topLeftCorner<3, 3>().determinant();
    variances.push_back(det > 0.0 ? std::cbrt(det) : 0.0);
  }
  return variances;
}

}  // namespace ccir_mapping::core::team
