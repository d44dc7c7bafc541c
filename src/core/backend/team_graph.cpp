#include "ccir_mapping/core/backend/team_graph.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numeric>
#include <stdexcept>
#include <tuple>

#include <Eigen/Geometry>

#include "ccir_mapping/core/backend/team_disagreement.h"
#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/core/pose_graph/g2o_io.h"

namespace ccir_mapping::core::backend {

using backend::BackendParams;
using pose_graph::Covariance6;
using pose_graph::inBodyFrame;
using pose_graph::LoopClosureData;
using pose_graph::OdometryUncertainty;
using pose_graph::OptimizationResult;
using pose_graph::OptimizerParams;
using pose_graph::PoseGraph;
using pose_graph::PoseGraphEdge;
using pose_graph::stepCovariance;

namespace {

/// A loop's miss is its translation error plus its rotation error times this: how far the
/// estimate puts the loop's scan's walls, at a typical range, from where the loop says.
constexpr double kLoopMissRadiusM = 10.0;

/// A windowed solve moves the teammate keyframes outside its window in rigid blocks of this many
/// consecutive ones: a chain that bends only between blocks (on bench_team_graph, seed 21, the
/// ATE along the mission equals that with every keyframe free within 0.1 mm).
constexpr std::size_t kBlockKeyframes = 20;

alignment::AlignmentParams emParams(const BackendParams& p) {
  alignment::AlignmentParams em;
  em.min_inliers = p.min_team_inliers;
  em.min_inlier_margin = p.team_inlier_margin;
  return em;
}

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
      odom_uncertainty_(params.odometry),
      gate_(emParams(params)) {
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
  solve_due_ = solve_due_ || loop_ends_.count({robot_, id});
  return true;
}

bool TeamGraph::addPeerKeyframe(const std::string& robot, KeyframeId id, const Pose3& pose) {
  if (robot == robot_ || robot.empty() || !isValidPose(pose)) return false;
  peers_[robot][id] = pose;
  solve_due_ = solve_due_ || loop_ends_.count({robot, id});
  return true;
}

bool TeamGraph::addLoopClosure(const LoopClosureData& loop) {
  if (!isValidPose(loop.relative) || !loop.covariance.allFinite()) return false;
  const bool own = loop.robot_from == robot_ || loop.robot_to == robot_;
  if (!own && loop.robot_from == loop.robot_to) return false;  // a teammate's own: never shared
  if (loop.robot_from == robot_ && loop.robot_to == robot_ &&
      loop.keyframe_from == loop.keyframe_to) {
    return false;
  }
  const Eigen::LLT<Matrix6> llt(loop.covariance);
  if (llt.info() != Eigen::Success || knows(loop)) return false;
  loops_.push_back(loop);
  loop_keys_.insert(keyOf(loop));
  loop_ends_.insert({loop.robot_from, loop.keyframe_from});
  loop_ends_.insert({loop.robot_to, loop.keyframe_to});
  solve_due_ = true;
  return true;
}

LoopKey TeamGraph::keyOf(const LoopClosureData& loop) {
  KeyframeOf from{loop.robot_from, loop.keyframe_from};
  KeyframeOf to{loop.robot_to, loop.keyframe_to};
  return from < to ? LoopKey{from, to} : LoopKey{to, from};
}

bool TeamGraph::knows(const LoopClosureData& loop) const { return loop_keys_.count(keyOf(loop)); }

std::optional<TeamGraph::Oriented> TeamGraph::oriented(const LoopClosureData& loop) const {
  if (loop.robot_from == loop.robot_to) return std::nullopt;
  const bool own = loop.robot_from == robot_ || loop.robot_to == robot_;
  if (own ? loop.robot_from == robot_ : loop.robot_from < loop.robot_to) {
    return Oriented{
        {loop.robot_from, loop.robot_to}, loop.keyframe_from, loop.keyframe_to, loop.relative};
  }
  return Oriented{{loop.robot_to, loop.robot_from},
                  loop.keyframe_to,
                  loop.keyframe_from,
                  loop.relative.inverse()};
}

int TeamGraph::ownIndex(KeyframeId id) const {
  const auto it = index_.find(id);
  return it == index_.end() ? -1 : it->second;
}

void TeamGraph::placeJoinedKeyframes() {
  for (auto& [peer, joined] : joined_) {
    const Pose3* previous = nullptr;
    const Pose3* previous_placed = nullptr;
    for (const auto& [id, pose] : peers_.at(peer)) {
      auto placed = joined.poses.find(id);
      if (placed == joined.poses.end()) {
        const Pose3 at = previous ? Pose3(*previous_placed * previous->inverse() * pose)
                                  : Pose3(joined.transform * pose);
        placed = joined.poses.emplace(id, at).first;
        joined.unsolved.insert(id);
      }
      previous = &pose;
      previous_placed = &placed->second;
    }
  }
}

TeamGraph::Assembled TeamGraph::assemble() const {
  Assembled a;
  a.graph = graph_;  // own keyframes and odometry
  a.own_count = a.graph.poses.size();
  for (const KeyframeId id : ids_) a.nodes.emplace_back(robot_, id);
  a.edge_keys.resize(a.graph.edges.size());
  a.edge_links.resize(a.graph.edges.size());
  const auto add_loop = [&](int from, int to, const LoopClosureData& loop, const Pose3& relative,
                            const std::optional<Link>& link) {
    PoseGraphEdge edge;
    edge.from = from;
    edge.to = to;
    edge.measurement = relative;
    edge.information = loop.covariance.inverse();  // first order for an inverted direction
    edge.loop = true;
    a.graph.edges.push_back(edge);
    a.edge_keys.push_back(keyOf(loop));
    a.edge_links.push_back(link);
  };
  for (const auto& loop : loops_) {
    if (loop.robot_from != robot_ || loop.robot_to != robot_) continue;
    const int from = ownIndex(loop.keyframe_from);
    const int to = ownIndex(loop.keyframe_to);
    if (from < 0 || to < 0) continue;
    add_loop(from, to, loop, loop.relative, std::nullopt);
    ++a.loops.intra;
  }
  // Each joined teammate's known keyframes in id order, chained by its odometry steps.
  std::map<KeyframeOf, int> peer_node;
  for (const auto& [peer, joined] : joined_) {
    const Pose3* previous = nullptr;
    for (const auto& [id, pose] : peers_.at(peer)) {
      const int node = static_cast<int>(a.graph.poses.size());
      a.graph.poses.push_back(joined.poses.at(id));
      if (previous) {
        PoseGraphEdge edge;
        edge.from = node - 1;
        edge.to = node;
        edge.measurement = previous->inverse() * pose;  // drift grows with the distance between
        edge.information = stepCovariance(edge.measurement, params_.odometry).inverse();
        a.graph.edges.push_back(edge);
        a.edge_keys.emplace_back();
        a.edge_links.emplace_back();
      }
      previous = &pose;
      peer_node[{peer, id}] = node;
      a.nodes.emplace_back(peer, id);
    }
  }
  // Inter-robot loops whose keyframes are both in the graph (own and joined teammates'): in it
  // when gated in, else reported rejected.
  const auto node_of = [&](const std::string& robot, KeyframeId id) {
    if (robot == robot_) return ownIndex(id);
    const auto it = peer_node.find({robot, id});
    return it == peer_node.end() ? -1 : it->second;
  };
  for (const auto& loop : loops_) {
    const auto inter = oriented(loop);
    if (!inter) continue;
    const auto& [link, first, second, relative] = *inter;
    const int from = node_of(link.first, first);
    const int to = node_of(link.second, second);
    if (from < 0 || to < 0) continue;
    ++a.loops.inter;
    if (gate_.admits(link, keyOf(loop))) {
      add_loop(from, to, loop, relative, link);
    } else {
      a.gated_out.emplace_back(from, to);
    }
  }
  return a;
}

TeamGraph::Window TeamGraph::window(const Assembled& a) const {
  const auto size = static_cast<std::size_t>(params_.solve_window_keyframes);
  const std::size_t n = a.graph.poses.size();
  Window w{std::vector<bool>(n, true), std::vector<int>(n, -1)};
  // Own keyframes: the newest, and all placed by odometry since the last solve; the rest held,
  // but for a new own loop with both keyframes held or that the estimate misses by a revisit's
  // drift: every own keyframe back to its older end is freed, where that drift grew (the part
  // before it is where the older end's earlier loops hold it).
  std::size_t first =
      std::min(a.own_count - std::min(a.own_count, size), std::min(solved_own_, a.own_count));
  const auto& poses = a.graph.poses;
  for (std::size_t k = 0; k < a.graph.edges.size(); ++k) {
    const PoseGraphEdge& e = a.graph.edges[k];
    if (!e.loop || a.edge_links[k] || loop_states_.count(a.edge_keys[k])) continue;
    const auto older = static_cast<std::size_t>(std::min(e.from, e.to));
    const auto newer = static_cast<std::size_t>(std::max(e.from, e.to));
    // How far the estimate misses the loop where its scan's walls are.
    const Pose3 miss = e.measurement.inverse() * poses[static_cast<std::size_t>(e.from)].inverse() *
                       poses[static_cast<std::size_t>(e.to)];
    const double miss_m =
        miss.translation().norm() + kLoopMissRadiusM * Eigen::AngleAxisd(miss.linear()).angle();
    if (newer < first || miss_m > params_.revisit_loop_error_m) first = std::min(first, older);
  }
  for (std::size_t i = 0; i < first; ++i) w.variable[i] = false;
  w.variable[0] = false;  // the gauge
  // Each teammate's (consecutive nodes): the newest and those placed since the last solve free,
  // the rest in rigid blocks of kBlockKeyframes, each moving with its newest keyframe. A
  // teammate's keyframe always moves, so its inter-robot loops need nothing more.
  for (std::size_t begin = a.own_count; begin < n;) {
    const std::string& peer = a.nodes[begin].first;
    std::size_t end = begin;
    while (end < n && a.nodes[end].first == peer) ++end;
    const auto& unsolved = joined_.at(peer).unsolved;
    std::vector<std::size_t> held;
    for (std::size_t i = begin; i + size < end; ++i) {
      if (!unsolved.count(a.nodes[i].second)) held.push_back(i);
    }
    for (std::size_t chunk = 0; chunk < held.size(); chunk += kBlockKeyframes) {
      const std::size_t last = std::min(chunk + kBlockKeyframes, held.size()) - 1;
      for (std::size_t j = chunk; j <= last; ++j) {
        w.variable[held[j]] = j == last;
        w.block[held[j]] = static_cast<int>(held[last]);
      }
    }
    begin = end;
  }
  return w;
}

int TeamGraph::solve(Assembled& a, bool full, double max_time_s, BackendSnapshot& snapshot) {
  PoseGraph& graph = a.graph;
  const std::size_t n = graph.poses.size();
  if (n < 2) return 0;
  std::optional<Window> w;
  if (!full && params_.solve_window_keyframes > 0) w.emplace(window(a));
  const bool whole = !w;
  snapshot.solved = whole ? BackendSnapshot::Solve::kFull : BackendSnapshot::Solve::kWindow;
  if (whole) {
    w.emplace(Window{std::vector<bool>(n, true), std::vector<int>(n, -1)});
    w->variable[0] = false;
  }
  const std::vector<bool>& variable = w->variable;
  // The problem: the variable poses, the constant ones an edge ties them to, and those edges. A
  // keyframe of a teammate's block enters as the block's node times its offset from it.
  const auto node_of = [&](int i) {
    const int block = w->block[static_cast<std::size_t>(i)];
    return static_cast<std::size_t>(block < 0 ? i : block);
  };
  const auto offset_of = [&](int i) {
    const int block = w->block[static_cast<std::size_t>(i)];
    return block < 0 || block == i ? Pose3::Identity()
                                   : Pose3(graph.poses[static_cast<std::size_t>(block)].inverse() *
                                           graph.poses[static_cast<std::size_t>(i)]);
  };
  std::vector<int> sub_index(n, -1);
  std::vector<std::size_t> sub_edges;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const std::size_t from = node_of(graph.edges[k].from);
    const std::size_t to = node_of(graph.edges[k].to);
    if (from == to || (!variable[from] && !variable[to])) continue;
    sub_edges.push_back(k);
    sub_index[from] = sub_index[to] = 0;
  }
  PoseGraph sub;
  sub.dimension = graph.dimension;
  pose_graph::SolveStart start;
  std::vector<std::size_t> sub_nodes;
  for (std::size_t i = 0; i < n; ++i) {
    if (sub_index[i] < 0) continue;
    sub_index[i] = static_cast<int>(sub.poses.size());
    sub.poses.push_back(graph.poses[i]);
    start.fixed.push_back(!variable[i]);
    sub_nodes.push_back(i);
  }
  for (const std::size_t k : sub_edges) {
    PoseGraphEdge edge = graph.edges[k];
    edge.from_offset = offset_of(edge.from);
    edge.to_offset = offset_of(edge.to);
    edge.from = sub_index[node_of(edge.from)];
    edge.to = sub_index[node_of(edge.to)];
    sub.edges.push_back(std::move(edge));
    // A windowed solve resumes each loop's switch; a full one starts every switch afresh.
    const auto state = loop_states_.find(a.edge_keys[k]);
    start.switches.push_back(graph.edges[k].loop && !whole && state != loop_states_.end()
                                 ? state->second.switch_value
                                 : optimizer_.initialSwitch());
  }
  if (sub.poses.size() < 2) return 0;
  solved_own_ = a.own_count;
  for (auto& [peer, joined] : joined_) joined.unsolved.clear();
  const OptimizationResult result = optimizer_.optimize(sub, max_time_s, start);
  int solved = 0;
  std::map<std::size_t, Pose3> block_moves;  // per block's node: its new pose times its old one^-1
  for (std::size_t j = 0; j < sub_nodes.size(); ++j) {
    const std::size_t i = sub_nodes[j];
    if (!variable[i]) continue;
    const double moved = (graph.poses[i].translation() - sub.poses[j].translation()).norm();
    if (whole) snapshot.full_correction_m = std::max(snapshot.full_correction_m, moved);
    if (w->block[i] >= 0) block_moves[i] = sub.poses[j] * graph.poses[i].inverse();
    graph.poses[i] = sub.poses[j];
    ++solved;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const int block = w->block[i];
    if (block < 0 || static_cast<std::size_t>(block) == i) continue;
    const auto move = block_moves.find(static_cast<std::size_t>(block));
    if (move != block_moves.end()) graph.poses[i] = move->second * graph.poses[i];
  }
  for (std::size_t j = 0; j < sub_edges.size(); ++j) {
    if (!sub.edges[j].loop) continue;
    loop_states_[a.edge_keys[sub_edges[j]]] = {result.switches[j], result.weights[j],
                                               result.inliers[j]};
  }
  return solved;
}

void TeamGraph::keep(Assembled&& a, BackendSnapshot& snapshot) {
  PoseGraph& graph = a.graph;
  graph_.poses.assign(graph.poses.begin(), graph.poses.begin() + a.own_count);
  for (std::size_t k = a.own_count; k < graph.poses.size(); ++k) {
    const auto& [peer, id] = a.nodes[k];
    joined_.at(peer).poses[id] = graph.poses[k];
  }
  snapshot.loops = a.loops;
  snapshot.loop_lines.clear();
  std::map<Link, std::set<LoopKey>> kept;
  last_weights_.assign(graph.edges.size(), 1.0);
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& e = graph.edges[k];
    if (!e.loop) continue;
    const auto state = loop_states_.find(a.edge_keys[k]);  // a new one: until its first solve
    const bool accepted = state == loop_states_.end() || state->second.inlier;
    last_weights_[k] = state == loop_states_.end() ? 1.0 : state->second.weight;
    const bool inter = a.edge_links[k].has_value();
    if (inter) {
      if (accepted) kept[*a.edge_links[k]].insert(a.edge_keys[k]);
      snapshot.loops.inter_rejected += !accepted;
    } else {
      snapshot.loops.intra_rejected += !accepted;
    }
    snapshot.loop_lines.push_back({graph.poses[static_cast<std::size_t>(e.from)].translation(),
                                   graph.poses[static_cast<std::size_t>(e.to)].translation(),
                                   accepted, inter});
  }
  for (const auto& [from, to] : a.gated_out) {
    ++snapshot.loops.inter_rejected;
    snapshot.loop_lines.push_back({graph.poses[static_cast<std::size_t>(from)].translation(),
                                   graph.poses[static_cast<std::size_t>(to)].translation(), false,
                                   true});
  }
  gate_.keep(std::move(kept));
  last_graph_ = std::move(graph);
  last_own_count_ = a.own_count;
  last_nodes_ = std::move(a.nodes);
}

PoseGraph TeamGraph::exportGraph(std::vector<double>* switch_values,
                                 std::vector<std::string>* robots) const {
  std::set<std::string> names;
  for (const auto& node : last_nodes_) names.insert(node.first);
  if (names.size() > 26) throw std::length_error("exportGraph: more robots than letters a-z");
  robots->assign(names.begin(), names.end());
  std::map<std::string, char> letter;
  for (std::size_t r = 0; r < robots->size(); ++r) letter[(*robots)[r]] = char('a' + r);
  // Nodes sorted by their keys, as PoseGraph::keys must be.
  std::vector<pose_graph::VertexKey> keys;
  for (const auto& [robot, id] : last_nodes_) keys.push_back({letter[robot], id});
  std::vector<int> order(keys.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return keys[a] < keys[b]; });
  std::vector<int> position(keys.size());
  PoseGraph out;
  out.dimension = last_graph_.dimension;
  for (std::size_t i = 0; i < order.size(); ++i) {
    position[static_cast<std::size_t>(order[i])] = static_cast<int>(i);
    out.poses.push_back(last_graph_.poses[static_cast<std::size_t>(order[i])]);
    out.keys.push_back(keys[static_cast<std::size_t>(order[i])]);
  }
  out.edges = last_graph_.edges;
  for (auto& e : out.edges) {
    e.from = position[static_cast<std::size_t>(e.from)];
    e.to = position[static_cast<std::size_t>(e.to)];
  }
  *switch_values = last_weights_;
  return out;
}

std::map<Link, TeamGraph::Candidates> TeamGraph::candidates() const {
  // Inter-robot loops along their links: own keyframes at their optimised poses, teammates' at
  // their own; each with the drift of both keyframes since their robots' starts (a teammate's
  // from its keyframes' poses, with this robot's odometry model), so that a true loop seen
  // after long drift still agrees and the least drifted loops weigh most.
  std::map<std::string, std::map<KeyframeId, Covariance6>> peer_covariances;
  for (const auto& [peer, keyframes] : peers_) peer_covariances[peer] = peerDrift(peer);
  // A keyframe's pose (own: optimised; a teammate's: its own), odometry pose and drift.
  struct Known {
    Pose3 pose, odom;
    Covariance6 drift;
  };
  const auto known = [&](const std::string& robot, KeyframeId id) -> std::optional<Known> {
    if (robot == robot_) {
      const int i = ownIndex(id);
      if (i < 0) return std::nullopt;
      const auto k = static_cast<std::size_t>(i);
      return Known{graph_.poses[k], odom_poses_[k], odom_covariances_[k]};
    }
    const auto peer = peers_.find(robot);
    if (peer == peers_.end()) return std::nullopt;
    const auto it = peer->second.find(id);
    if (it == peer->second.end()) return std::nullopt;
    return Known{it->second, it->second, peer_covariances.at(robot).at(id)};
  };
  std::map<Link, Candidates> candidates;
  for (const auto& loop : loops_) {
    const auto inter = oriented(loop);
    if (!inter) continue;
    const auto& [link, first, second, relative] = *inter;
    const auto a = known(link.first, first);
    const auto b = known(link.second, second);
    if (!a || !b) continue;
    alignment::AlignmentCandidate c;
    c.pose_a = a->pose;
    c.pose_b = b->pose;
    c.measurement = relative;
    c.covariance = loop.covariance;  // a first-order approximation for the inverted direction
    c.covariance_a = inBodyFrame(a->drift, a->odom.linear());
    c.covariance_b = inBodyFrame(b->drift, b->odom.linear() * relative.linear().transpose());
    candidates[link].list.push_back(c);
    candidates[link].keys.push_back(keyOf(loop));
  }
  return candidates;
}

std::map<KeyframeId, Covariance6> TeamGraph::peerDrift(const std::string& peer) const {
  std::map<KeyframeId, Covariance6> drift;
  OdometryUncertainty chain(params_.odometry);
  for (const auto& [id, pose] : peers_.at(peer)) drift[id] = chain.advance(pose);
  return drift;
}

Pose3 TeamGraph::refinedTransform(const std::string& peer) const {
  // Where the graph puts the teammate's frame: a rigid fit (x y yaw; both frames are
  // gravity-aligned) from its own poses to its optimised ones, each weighted by how little its
  // odometry had drifted (the frame's origin is where the drift is zero); z by the weighted
  // mean. Written here: Eigen's umeyama has no weights.
  const Joined& joined = joined_.at(peer);
  const auto& raw = peers_.at(peer);
  const auto drift = peerDrift(peer);
  double total = 0.0;
  Eigen::Vector3d from_mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d to_mean = Eigen::Vector3d::Zero();
  std::vector<std::tuple<double, Eigen::Vector3d, Eigen::Vector3d>> pairs;
  for (const auto& [id, pose] : joined.poses) {
    const double w = 1.0 / (drift.at(id).topLeftCorner<3, 3>().trace() + 1e-4);
    pairs.emplace_back(w, raw.at(id).translation(), pose.translation());
    total += w;
    from_mean += w * raw.at(id).translation();
    to_mean += w * pose.translation();
  }
  if (pairs.empty()) return joined.transform;
  from_mean /= total;
  to_mean /= total;
  double sin_sum = 0.0;
  double cos_sum = 0.0;
  for (const auto& [w, p, q] : pairs) {
    const Eigen::Vector2d a = (p - from_mean).head<2>();
    const Eigen::Vector2d b = (q - to_mean).head<2>();
    cos_sum += w * a.dot(b);
    sin_sum += w * (a.x() * b.y() - a.y() * b.x());
  }
  double yaw = std::atan2(sin_sum, cos_sum);
  if (std::hypot(sin_sum, cos_sum) < 1e-9 * total) {  // one place: its pose's heading decides
    const auto& [id, pose] = *joined.poses.begin();
    const Eigen::Matrix3d turn = pose.linear() * raw.at(id).linear().transpose();
    yaw = std::atan2(turn(1, 0), turn(0, 0));
  }
  Pose3 transform = Pose3::Identity();
  transform.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  transform.translation() = to_mean - transform.linear() * from_mean;
  return transform;
}

void TeamGraph::judgeLinks(BackendSnapshot& snapshot, std::vector<LoopLine>& em_lines,
                           const std::function<double()>& elapsed_s) {
  gate_.clearAdmitted();
  // Own links first: a teammate that joins now lets in its links with the others in the graph.
  const auto all_candidates = candidates();
  std::vector<const std::pair<const Link, Candidates>*> links;
  for (const auto& entry : all_candidates) {
    if (entry.first.first == robot_) links.push_back(&entry);
  }
  for (const auto& entry : all_candidates) {
    if (entry.first.first != robot_) links.push_back(&entry);
  }
  std::size_t links_left = links.size();
  for (const auto* entry : links) {
    const auto& [link, candidates] = *entry;
    const auto& list = candidates.list;
    const bool own = link.first == robot_;
    if (!own && !(joined_.count(link.first) && joined_.count(link.second))) {
      --links_left;  // its closures could not enter the graph
      continue;
    }
    // Its share of what the EM has left (its best supported start runs whatever is left).
    const double em_s = std::max(kEmTimeShare * params_.max_solve_time_s - elapsed_s(), 1e-6) /
                        static_cast<double>(links_left--);
    if (!own) {  // two teammates' closures: the EM only gates them
      gate_.admit(link, candidates.keys, gate_.judge(link, list, true, em_s));
      continue;
    }
    const std::string& peer = link.second;
    TeamEstimate estimate;
    estimate.peer = peer;
    estimate.candidates = static_cast<int>(list.size());
    estimate.alignment = gate_.judge(link, list, joined_.count(peer) > 0, em_s);
    const alignment::AlignmentResult& found = estimate.alignment;
    auto joined = joined_.find(peer);
    if (joined == joined_.end() && found.found && params_.team_graph) {
      joined = joined_.emplace(peer, Joined{found.transform, {}, {}}).first;
      full_due_ = true;
      snapshot.notices.push_back(
          {"team graph", peer + " joins the graph: " + std::to_string(found.inlier_count) + " of " +
                             std::to_string(list.size()) + " closures agree"});
    } else if (joined != joined_.end() && found.found) {
      int em_inliers = 0;  // among the closures the graph has judged too
      for (std::size_t k = 0; k < list.size(); ++k) {
        em_inliers += found.inliers[k] && loop_states_.count(candidates.keys[k]);
      }
      const int accepted = static_cast<int>(gate_.keptCount(link));
      const TeamDisagreement judged =
          judgeDisagreement(refinedTransform(peer), joined->second.transform, found.transform,
                            accepted, em_inliers, params_);
      using Verdict = TeamDisagreement::Verdict;
      if (judged.verdict != Verdict::kAgree) {
        char head[160];
        std::snprintf(head, sizeof head,
                      "the EM transform to %s is %.2f m / %.1f deg from the graph's", peer.c_str(),
                      judged.shift_m, judged.turn_deg);
        const std::string counts = std::to_string(accepted) + " closures, the EM " +
                                   std::to_string(em_inliers) + " of them";
        std::string text = head;
        if (judged.verdict == Verdict::kKeepGraph) {
          text += "; keeping the graph's: its switches accept " + counts;
        } else if (judged.verdict == Verdict::kTriedBefore) {
          text += ", which accepts only " + counts + "; keeping the graph's: " + peer +
                  " was placed with that transform already";
        } else {
          text += "; the graph accepts only " + counts + ": " + peer +
                  " placed again with the EM transform";
          joined->second = {found.transform, {}, {}};
          gate_.forgetKept(link);
          full_due_ = true;
        }
        snapshot.notices.push_back({"team disagreement", text});
      }
    }
    if (joined != joined_.end()) gate_.admit(link, candidates.keys, found);
    for (std::size_t k = 0; found.found && joined == joined_.end() && k < list.size(); ++k) {
      if (!found.inliers[k]) continue;
      em_lines.push_back({list[k].pose_a.translation(),
                          (found.transform * list[k].pose_b).translation(), true, true});
    }
    snapshot.team.push_back(estimate);
  }
}

BackendSnapshot TeamGraph::optimize() {
  BackendSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed_s = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const bool period_full = windowed_since_full_ && last_full_ && !stamps_.empty() &&
                           stamps_.back() - *last_full_ >= fromSeconds(params_.full_solve_period_s);
  std::vector<LoopLine> em_lines;  // of teammates out of the graph (only without team_graph)
  if (solve_due_) {
    judgeLinks(snapshot, em_lines, elapsed_s);
  } else {
    snapshot.team = last_team_;
    em_lines = last_em_lines_;
  }
  placeJoinedKeyframes();
  Assembled assembled = assemble();
  if (solve_due_ || period_full) {
    // A teammate that joined or was placed again is optimised now.
    snapshot.solved_poses = solve(assembled, full_due_ || period_full,
                                  std::max(params_.max_solve_time_s - elapsed_s(), 1e-3), snapshot);
    if (snapshot.solved == BackendSnapshot::Solve::kFull) {
      full_due_ = windowed_since_full_ = false;
      if (!stamps_.empty()) last_full_ = stamps_.back();
    } else {
      windowed_since_full_ = true;
    }
  }
  keep(std::move(assembled), snapshot);
  snapshot.loop_lines.insert(snapshot.loop_lines.end(), em_lines.begin(), em_lines.end());
  if (snapshot.solved != BackendSnapshot::Solve::kNone) {
    for (auto& estimate : snapshot.team) {
      if (!joined_.count(estimate.peer)) continue;
      estimate.in_graph = true;
      estimate.alignment.found = true;
      estimate.alignment.transform = refinedTransform(estimate.peer);
    }
  }
  last_team_ = snapshot.team;
  last_em_lines_ = em_lines;
  for (const auto& [peer, joined] : joined_) {
    PeerKeyframes keyframes;
    keyframes.robot = peer;
    for (const auto& [id, pose] : joined.poses) {
      keyframes.ids.push_back(id);
      keyframes.poses.push_back(pose);
    }
    snapshot.peer_keyframes.push_back(std::move(keyframes));
  }

  snapshot.ids = ids_;
  snapshot.stamps = stamps_;
  snapshot.poses = graph_.poses;
  if (!odom_poses_.empty()) snapshot.latest_odom_pose = odom_poses_.back();
  snapshot.solve_s = elapsed_s();
  snapshot.cut_short = snapshot.solved != BackendSnapshot::Solve::kNone &&
                       snapshot.solve_s >= params_.max_solve_time_s;
  // Cut short: solved again at the next call, in the window. A full solve goes on from where it
  // stopped at the next full_solve_period_s: one too large for max_solve_time_s repeated at
  // every call would cost the time box at every call.
  solve_due_ = snapshot.cut_short;
  return snapshot;
}

void TeamGraph::saveG2o(const std::string& path) const {
  std::vector<double> switches;
  std::vector<std::string> robots;
  const PoseGraph graph = exportGraph(&switches, &robots);
  pose_graph::writeG2o(graph, path, switches);
  // The letters' robots, for a reader: g2o readers skip comment lines.
  std::ofstream out(path, std::ios::app);
  for (std::size_t r = 0; r < robots.size(); ++r) {
    out << "# robot " << char('a' + r) << ": " << robots[r] << '\n';
  }
  if (!out) throw std::runtime_error("cannot write " + path);
}

TumTrajectory TeamGraph::trajectory() const { return {stamps_, graph_.poses}; }

TumTrajectory TeamGraph::odometry() const { return {stamps_, odom_poses_}; }

std::vector<std::string> TeamGraph::save(const std::string& dir) const {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create " + dir + ": " + error.message());
  const std::string graph = dir + "/team_graph.g2o";
  const std::string trajectory = dir + "/trajectory.tum";
  const std::string odometry = dir + "/odometry.tum";
  // Each written aside and renamed over the last save: a crash mid-save leaves whole files.
  const std::string aside = ".new";
  saveG2o(graph + aside);
  TumTrajectoryWriter::write(
      trajectory + aside,
      "stamp x y z qx qy qz qw: " + robot_ + "'s keyframes in its map frame (" +
          std::to_string(last_own_count_) + " optimised, newer ones by odometry)",
      this->trajectory());
  TumTrajectoryWriter::write(
      odometry + aside, "stamp x y z qx qy qz qw: " + robot_ + "'s keyframes in its odometry frame",
      this->odometry());
  for (const std::string& file : {graph, trajectory, odometry}) {
    std::filesystem::rename(file + aside, file, error);
    if (error) throw std::runtime_error("cannot write " + file + ": " + error.message());
  }
  return {graph, trajectory, odometry};
}

std::size_t TeamGraph::varianceStride() const {
  const std::size_t nodes = std::max(last_graph_.poses.size(), graph_.poses.size());
  return std::max(kVarianceAnchorEvery, (nodes + kVarianceNodes - 1) / kVarianceNodes);
}

std::optional<std::vector<Eigen::MatrixXd>> TeamGraph::covariances(
    const std::vector<KeyframeId>& ids) const {
  // The last optimised graph, loops weighted as the robust kernel left them (a loop the
  // switches accepted shrinks the uncertainty of the keyframes it closes), its chains thinned
  // to these keyframes and every varianceStride()-th pose, which the loops' ends move to: a
  // graph of at most ~kVarianceNodes poses, however long the mission.
  const bool optimised = last_own_count_ == graph_.poses.size();
  const PoseGraph& whole = optimised ? last_graph_ : graph_;
  std::vector<double> weights = optimised ? last_weights_ : std::vector<double>{};
  std::vector<bool> keep(whole.poses.size(), false);
  const std::size_t stride = varianceStride();
  for (std::size_t i = 0; i < keep.size(); i += stride) keep[i] = true;
  for (const KeyframeId id : ids) {
    const auto it = index_.find(id);
    if (it == index_.end()) return std::nullopt;
    keep[static_cast<std::size_t>(it->second)] = true;
  }
  std::vector<int> node_of;
  const PoseGraph thin = pose_graph::thinChains(whole, keep, &node_of, &weights);
  std::vector<int> indices;
  for (const KeyframeId id : ids)
    indices.push_back(node_of[static_cast<std::size_t>(index_.at(id))]);
  return optimizer_.marginalCovariances(thin, indices, weights);
}

std::optional<std::vector<double>> TeamGraph::positionVariances(
    const std::vector<KeyframeId>& ids) const {
  // Marginals at every varianceStride()-th keyframe and the last; between, each one's is the
  // one before it plus its odometry step's position variance.
  const std::size_t stride = varianceStride();
  std::vector<KeyframeId> anchors;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (i % stride == 0 || i + 1 == ids.size()) anchors.push_back(ids[i]);
  }
  const auto all = covariances(anchors);
  if (!all) return std::nullopt;
  std::vector<double> variances;
  std::size_t next = 0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (next < anchors.size() && anchors[next] == ids[i]) {
      // The position block leads (x y z, then rotation); the gauge keyframe's is 0.
      const double det = (*all)[next++].topLeftCorner<3, 3>().determinant();
      variances.push_back(det > 0.0 ? std::cbrt(det) : 0.0);
      continue;
    }
    const Pose3& before = graph_.poses[static_cast<std::size_t>(index_.at(ids[i - 1]))];
    const Pose3& at = graph_.poses[static_cast<std::size_t>(index_.at(ids[i]))];
    variances.push_back(variances.back() +
                        pose_graph::stepCovariance(before.inverse() * at, params_.odometry)(0, 0));
  }
  return variances;
}

}  // namespace ccir_mapping::core::backend
