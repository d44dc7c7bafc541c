#include "ccir_mapping/core/backend/team_graph.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <stdexcept>
#include <tuple>

#include <Eigen/Geometry>

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
  return true;
}

TeamGraph::LoopKey TeamGraph::keyOf(const LoopClosureData& loop) {
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

void TeamGraph::solve(BackendSnapshot& snapshot, double max_time_s) {
  snapshot.loop_lines.clear();
  snapshot.loops = {};
  PoseGraph graph = graph_;  // own keyframes and odometry
  const std::size_t own_count = graph.poses.size();
  for (const auto& loop : loops_) {
    if (loop.robot_from != robot_ || loop.robot_to != robot_) continue;
    const int from = ownIndex(loop.keyframe_from);
    const int to = ownIndex(loop.keyframe_to);
    if (from < 0 || to < 0) continue;
    PoseGraphEdge edge;
    edge.from = from;
    edge.to = to;
    edge.measurement = loop.relative;
    edge.information = loop.covariance.inverse();
    edge.loop = true;
    graph.edges.push_back(edge);
    ++snapshot.loops.intra;
  }
  // Each joined teammate's known keyframes, in id order: a keyframe placed before keeps its
  // optimised pose, a new one continues from the previous node by its odometry step (or is
  // placed with the transform when it is the first).
  std::map<std::pair<std::string, KeyframeId>, int> peer_node;
  std::vector<std::pair<std::string, KeyframeId>> node_keyframe;  // of nodes from own_count
  for (const auto& [peer, joined] : joined_) {
    const Pose3* previous = nullptr;
    for (const auto& [id, pose] : peers_.at(peer)) {
      const int node = static_cast<int>(graph.poses.size());
      if (const auto known = joined.poses.find(id); known != joined.poses.end()) {
        graph.poses.push_back(known->second);
      } else if (previous) {
        graph.poses.push_back(graph.poses.back() * previous->inverse() * pose);
      } else {
        graph.poses.push_back(joined.transform * pose);
      }
      if (previous) {
        PoseGraphEdge edge;
        edge.from = node - 1;
        edge.to = node;
        edge.measurement = previous->inverse() * pose;  // drift grows with the distance between
        edge.information = stepCovariance(edge.measurement, params_.odometry).inverse();
        graph.edges.push_back(edge);
      }
      previous = &pose;
      peer_node[{peer, id}] = node;
      node_keyframe.emplace_back(peer, id);
    }
  }
  // Inter-robot loops whose keyframes are both in the graph (own and joined teammates'): in it
  // when gated in, else reported rejected.
  const auto node_of = [&](const std::string& robot, KeyframeId id) {
    if (robot == robot_) return ownIndex(id);
    const auto it = peer_node.find({robot, id});
    return it == peer_node.end() ? -1 : it->second;
  };
  std::vector<std::pair<int, int>> gated_out;
  std::vector<std::pair<Link, LoopKey>> edge_loop;  // of each inter-robot edge, in order
  for (const auto& loop : loops_) {
    const auto inter = oriented(loop);
    if (!inter) continue;
    const auto& [link, first, second, relative] = *inter;
    const int from = node_of(link.first, first);
    const int to = node_of(link.second, second);
    if (from < 0 || to < 0) continue;
    ++snapshot.loops.inter;
    const LoopKey key = keyOf(loop);
    if (!gate_[link].count(key) && !kept_[link].count(key)) {
      gated_out.emplace_back(from, to);
      continue;
    }
    PoseGraphEdge edge;
    edge.from = from;
    edge.to = to;
    edge.measurement = relative;
    edge.information = loop.covariance.inverse();  // first order for the inverted direction
    edge.loop = true;
    graph.edges.push_back(edge);
    edge_loop.emplace_back(link, key);
  }

  kept_.clear();
  if (graph.poses.size() < 2) return;
  const OptimizationResult result = optimizer_.optimize(graph, max_time_s);
  graph_.poses.assign(graph.poses.begin(), graph.poses.begin() + own_count);
  for (std::size_t k = own_count; k < graph.poses.size(); ++k) {
    const auto& [peer, id] = node_keyframe[k - own_count];
    joined_.at(peer).poses[id] = graph.poses[k];
  }
  std::size_t inter = 0;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& e = graph.edges[k];
    if (!e.loop) continue;
    const auto to = static_cast<std::size_t>(e.to);
    const bool accepted = result.inliers[k];
    if (to >= own_count) {
      const auto& [link, key] = edge_loop[inter++];
      if (accepted) kept_[link].insert(key);
      snapshot.loops.inter_rejected += !accepted;
    } else {
      snapshot.loops.intra_rejected += !accepted;
    }
    snapshot.loop_lines.push_back({graph.poses[static_cast<std::size_t>(e.from)].translation(),
                                   graph.poses[to].translation(), accepted, to >= own_count});
  }
  for (const auto& [from, to] : gated_out) {
    ++snapshot.loops.inter_rejected;
    snapshot.loop_lines.push_back({graph.poses[static_cast<std::size_t>(from)].translation(),
                                   graph.poses[static_cast<std::size_t>(to)].translation(), false,
                                   true});
  }
  last_weights_ = result.weights;
  last_graph_ = std::move(graph);
  last_own_count_ = own_count;
  last_nodes_.clear();
  for (const KeyframeId id : ids_) last_nodes_.emplace_back(robot_, id);
  last_nodes_.insert(last_nodes_.end(), node_keyframe.begin(), node_keyframe.end());
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

std::map<TeamGraph::Link, TeamGraph::Candidates> TeamGraph::candidates() const {
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

BackendSnapshot TeamGraph::optimize() {
  BackendSnapshot snapshot;
  const auto start = std::chrono::steady_clock::now();
  alignment::AlignmentParams em;
  em.min_inliers = params_.min_team_inliers;
  em.min_inlier_margin = params_.team_inlier_margin;
  gate_.clear();
  std::vector<LoopLine> em_lines;  // of teammates out of the graph (only without team_graph)
  const auto elapsed_s = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  // The EM of a link, or (once its transform was found, until its closures grew by
  // kEmRerunGrowth since the last full EM) a re-check of that transform against them: O(n).
  const auto align = [&](const Link& link, const std::vector<alignment::AlignmentCandidate>& list,
                         bool recheck) {
    alignment::AlignmentResult result;
    const auto last = last_em_.find(link);
    if (recheck && last != last_em_.end() && last->second.second.found &&
        static_cast<double>(list.size()) < (1.0 + kEmRerunGrowth) * last->second.first) {
      result = alignment::checkFrameTransform(list, em, last->second.second);
    }
    if (!result.found) {
      result = alignment::estimateFrameTransform(list, em);
      last_em_[link] = {list.size(), result};
    }
    return result;
  };
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
    em.max_time_s = std::max(kEmTimeShare * params_.max_solve_time_s - elapsed_s(), 1e-6) /
                    static_cast<double>(links_left--);
    if (!own) {  // two teammates' closures: the EM only gates them
      const auto found = align(link, list, true);
      for (std::size_t k = 0; found.found && k < list.size(); ++k) {
        if (found.inliers[k]) gate_[link].insert(candidates.keys[k]);
      }
      continue;
    }
    const std::string& peer = link.second;
    TeamEstimate estimate;
    estimate.peer = peer;
    estimate.candidates = static_cast<int>(list.size());
    estimate.alignment = align(link, list, joined_.count(peer) > 0);
    const alignment::AlignmentResult& found = estimate.alignment;
    auto joined = joined_.find(peer);
    if (joined == joined_.end() && found.found && params_.team_graph) {
      joined = joined_.emplace(peer, Joined{found.transform, {}}).first;
      snapshot.notices.push_back(
          {"team graph", peer + " joins the graph: " + std::to_string(found.inlier_count) + " of " +
                             std::to_string(list.size()) + " closures agree"});
    } else if (joined != joined_.end() && found.found) {
      const Pose3 delta = refinedTransform(peer).inverse() * found.transform;
      const double shift_m = delta.translation().norm();
      const double turn_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180 / M_PI;
      if (shift_m > params_.team_disagreement_m || turn_deg > params_.team_disagreement_deg) {
        // The hypothesis with clearly more agreeing closures wins, by the EM's own margin.
        const int accepted = static_cast<int>(kept_[link].size());
        char text[320];
        if (accepted + params_.team_inlier_margin >= found.inlier_count) {
          std::snprintf(text, sizeof text,
                        "the EM transform to %s is %.2f m / %.1f deg from the graph's; keeping "
                        "the graph's: its switches accept %d closures, the EM %d",
                        peer.c_str(), shift_m, turn_deg, accepted, found.inlier_count);
        } else {
          std::snprintf(text, sizeof text,
                        "the EM transform to %s is %.2f m / %.1f deg from the graph's; the graph "
                        "accepts only %d closures, the EM %d: %s placed again with the EM "
                        "transform",
                        peer.c_str(), shift_m, turn_deg, accepted, found.inlier_count,
                        peer.c_str());
          joined->second = {found.transform, {}};
          kept_.erase(link);
        }
        snapshot.notices.push_back({"team disagreement", text});
      }
    }
    for (std::size_t k = 0; found.found && k < list.size(); ++k) {
      if (!found.inliers[k]) continue;
      if (joined != joined_.end()) {
        gate_[link].insert(candidates.keys[k]);
      } else {
        em_lines.push_back({list[k].pose_a.translation(),
                            (found.transform * list[k].pose_b).translation(), true, true});
      }
    }
    snapshot.team.push_back(estimate);
  }
  // A teammate that joined or was placed again is optimised now.
  solve(snapshot, std::max(params_.max_solve_time_s - elapsed_s(), 1e-3));
  snapshot.loop_lines.insert(snapshot.loop_lines.end(), em_lines.begin(), em_lines.end());
  for (auto& estimate : snapshot.team) {
    if (!joined_.count(estimate.peer)) continue;
    estimate.in_graph = true;
    estimate.alignment.found = true;
    estimate.alignment.transform = refinedTransform(estimate.peer);
  }
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
  snapshot.solve_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  snapshot.cut_short = snapshot.solve_s >= params_.max_solve_time_s;
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
  if (last_own_count_ != graph_.poses.size()) {
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

}  // namespace ccir_mapping::core::backend
