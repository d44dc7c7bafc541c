#include "ccir_mapping/core/pose_graph/g2o_io.h"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

namespace ccir_mapping::core::pose_graph {
namespace {

Pose3 planar(double x, double y, double theta) {
  Pose3 pose = Pose3::Identity();
  pose.translation() << x, y, 0.0;
  pose.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

Pose3 spatial(double x, double y, double z, double qx, double qy, double qz, double qw) {
  Pose3 pose = Pose3::Identity();
  pose.translation() << x, y, z;
  pose.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  return pose;
}

double yawOf(const Pose3& pose) { return std::atan2(pose.linear()(1, 0), pose.linear()(0, 0)); }

/// Scales between g2o's quaternion-vector rotation units and rotation-vector units (q ~ theta/2).
Information quaternionToRotationVector(Information info) {
  info.block<3, 3>(3, 3) /= 4.0;
  info.block<3, 3>(0, 3) /= 2.0;
  info.block<3, 3>(3, 0) /= 2.0;
  return info;
}

Information rotationVectorToQuaternion(Information info) {
  info.block<3, 3>(3, 3) *= 4.0;
  info.block<3, 3>(0, 3) *= 2.0;
  info.block<3, 3>(3, 0) *= 2.0;
  return info;
}

/// A vertex id: unsigned 64 bits (a robot-keyed one uses all of them). Throws for a negative
/// one, which the unsigned read would wrap around silently.
bool readId(std::istream& in, std::uint64_t* id) {
  if ((in >> std::ws).peek() == '-') throw std::invalid_argument("negative vertex id");
  return static_cast<bool>(in >> *id);
}

Information readUpperTriangle(std::istream& in, int n) {
  Information info(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = r; c < n; ++c) {
      if (!(in >> info(r, c))) throw std::invalid_argument("too few information values");
      info(c, r) = info(r, c);
    }
  }
  return info;
}

}  // namespace

std::size_t PoseGraph::loopCount() const {
  std::size_t loops = 0;
  for (const auto& e : edges) loops += e.loop;
  return loops;
}

PoseGraph readG2o(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error("cannot read the g2o file " + path);
  PoseGraph graph;
  graph.dimension = 0;
  std::map<std::uint64_t, Pose3> vertices;
  struct RawEdge {
    std::uint64_t from, to;
    PoseGraphEdge edge;
  };
  std::vector<RawEdge> raw_edges;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    std::istringstream in(line);
    std::string tag;
    if (!(in >> tag) || tag[0] == '#') continue;
    try {
      // The switches of an exported graph: their values are for the reader, not the optimiser.
      if (tag == "FIX" || tag == "VERTEX_SWITCH" || tag == "EDGE_SWITCH_PRIOR") continue;
      const bool switchable = tag == "EDGE_SE2_SWITCHABLE" || tag == "EDGE_SE3_SWITCHABLE";
      const int dimension =
          tag == "VERTEX_SE2" || tag == "EDGE_SE2" || tag == "EDGE_SE2_SWITCHABLE"             ? 2
          : tag == "VERTEX_SE3:QUAT" || tag == "EDGE_SE3:QUAT" || tag == "EDGE_SE3_SWITCHABLE" ? 3
                                                                                               : 0;
      if (dimension == 0) throw std::invalid_argument("unsupported element '" + tag + "'");
      if (graph.dimension != 0 && graph.dimension != dimension) {
        throw std::invalid_argument("mixes 2D and 3D elements");
      }
      graph.dimension = dimension;
      std::uint64_t id = 0;
      if (tag == "VERTEX_SE2") {
        double x, y, theta;
        if (!readId(in, &id) || !(in >> x >> y >> theta))
          throw std::invalid_argument("bad VERTEX_SE2");
        vertices[id] = planar(x, y, theta);
      } else if (tag == "VERTEX_SE3:QUAT") {
        double v[7];
        if (!readId(in, &id) || !(in >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])) {
          throw std::invalid_argument("bad VERTEX_SE3:QUAT");
        }
        vertices[id] = spatial(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
      } else {
        RawEdge raw;
        PoseGraphEdge& edge = raw.edge;
        std::uint64_t switch_id = 0;
        if (!readId(in, &raw.from) || !readId(in, &raw.to) || raw.from == raw.to ||
            (switchable && !(in >> switch_id))) {
          throw std::invalid_argument("bad edge ids");
        }
        if (dimension == 2) {
          double x, y, theta;
          if (!(in >> x >> y >> theta)) throw std::invalid_argument("bad " + tag);
          edge.measurement = planar(x, y, theta);
          edge.information = readUpperTriangle(in, 3);
        } else {
          double v[7];
          if (!(in >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])) {
            throw std::invalid_argument("bad " + tag);
          }
          edge.measurement = spatial(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
          edge.information = quaternionToRotationVector(readUpperTriangle(in, 6));
        }
        if (!edge.information.allFinite()) throw std::invalid_argument("non-finite information");
        edge.loop = switchable;
        raw_edges.push_back(raw);
      }
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + e.what());
    }
  }
  if (graph.dimension == 0) throw std::runtime_error(path + ": no pose graph in it");

  // Robot-keyed ids (a multi-robot graph) or plain ones 0..n-1, never both.
  std::set<std::uint64_t> ids;
  for (const auto& [id, pose] : vertices) ids.insert(id);
  for (const auto& r : raw_edges) ids.insert({r.from, r.to});
  const auto keyed = [](std::uint64_t id) { return VertexKey::fromId(id).robot != 0; };
  const bool multi_robot = keyed(*ids.rbegin());
  if (multi_robot && !keyed(*ids.begin())) {
    throw std::runtime_error(path + ": mixes plain and robot-keyed vertex ids");
  }
  std::map<std::uint64_t, int> index;
  if (multi_robot) {
    if (vertices.size() != ids.size()) {
      throw std::runtime_error(path + ": a multi-robot graph needs a vertex for every pose");
    }
    for (const std::uint64_t id : ids) {
      index.emplace(id, static_cast<int>(graph.keys.size()));
      graph.keys.push_back(VertexKey::fromId(id));
    }
  } else {
    const std::uint64_t count = *ids.rbegin() + 1;
    if (count > std::uint64_t(std::numeric_limits<int>::max())) {
      throw std::runtime_error(path + ": vertex id " + std::to_string(count - 1) + " too large");
    }
    // Checked before the index is made: one vertex numbered in the millions made as many
    // entries (found by fuzz_g2o_reader).
    if (ids.size() != count || (!vertices.empty() && vertices.size() != count)) {
      throw std::runtime_error(path + ": vertex ids are not 0.." + std::to_string(count - 1));
    }
    for (const std::uint64_t id : ids) index.emplace(id, static_cast<int>(id));
  }
  // Odometry: every plain edge when there are switchable ones (Vertigo's convention, and that of
  // an exported team graph, whose teammates' keyframe ids are not consecutive); otherwise the
  // first edge between consecutive poses of one robot. The rest are loops.
  const bool switchable =
      std::any_of(raw_edges.begin(), raw_edges.end(), [](const RawEdge& r) { return r.edge.loop; });
  std::set<std::pair<int, int>> odometry_pairs;
  for (auto& [from, to, edge] : raw_edges) {
    edge.from = index.at(from);
    edge.to = index.at(to);
    const bool consecutive =
        VertexKey::fromId(from).robot == VertexKey::fromId(to).robot && to == from + 1;
    if (!switchable)
      edge.loop = !(consecutive && odometry_pairs.insert({edge.from, edge.to}).second);
    graph.edges.push_back(edge);
  }
  graph.poses.assign(index.size(), Pose3::Identity());
  if (!vertices.empty()) {
    for (const auto& [id, pose] : vertices) graph.poses[static_cast<std::size_t>(index[id])] = pose;
  } else {
    // No vertices (a single robot's graph): chain the odometry for the initial guess.
    std::vector<const PoseGraphEdge*> step(graph.poses.size(), nullptr);
    for (const auto& e : graph.edges) {
      if (!e.loop) step[static_cast<std::size_t>(e.to)] = &e;
    }
    for (std::size_t i = 1; i < graph.poses.size(); ++i) {
      if (!step[i]) {
        throw std::runtime_error(path + ": no vertices and no odometry edge to " +
                                 std::to_string(i));
      }
      graph.poses[i] = graph.poses[i - 1] * step[i]->measurement;
    }
  }
  return graph;
}

void writeG2o(const PoseGraph& graph, const std::string& path,
              const std::vector<double>& loop_weights) {
  if (!graph.keys.empty() && graph.keys.size() != graph.poses.size()) {
    throw std::invalid_argument("writeG2o: keys and poses differ in number");
  }
  const bool switches = !loop_weights.empty();
  if (switches && loop_weights.size() != graph.edges.size()) {
    throw std::invalid_argument("writeG2o: one weight per edge needed");
  }
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << std::setprecision(12);
  const auto id = [&](std::size_t i) -> std::uint64_t {
    return graph.keys.empty() ? i : graph.keys[i].id();
  };
  for (std::size_t i = 0; i < graph.poses.size(); ++i) {
    const Pose3& p = graph.poses[i];
    if (graph.dimension == 2) {
      out << "VERTEX_SE2 " << id(i) << ' ' << p.translation().x() << ' ' << p.translation().y()
          << ' ' << yawOf(p) << '\n';
    } else {
      const Eigen::Quaterniond q(p.linear());
      out << "VERTEX_SE3:QUAT " << id(i) << ' ' << p.translation().transpose() << ' ' << q.x()
          << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
    }
  }
  // Switch ids follow the poses' (a keyed graph's pose ids are all above 2^56).
  std::uint64_t next_switch = graph.keys.empty() ? graph.poses.size() : 0;
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const PoseGraphEdge& e = graph.edges[k];
    const bool switched = switches && e.loop;
    const std::string tag = graph.dimension == 2
                                ? (switched ? "EDGE_SE2_SWITCHABLE" : "EDGE_SE2")
                                : (switched ? "EDGE_SE3_SWITCHABLE" : "EDGE_SE3:QUAT");
    if (switched) {
      out << "VERTEX_SWITCH " << next_switch << ' ' << loop_weights[k] << '\n'
          << "EDGE_SWITCH_PRIOR " << next_switch << " 1 1\n";
    }
    out << tag << ' ' << id(static_cast<std::size_t>(e.from)) << ' '
        << id(static_cast<std::size_t>(e.to));
    if (switched) out << ' ' << next_switch++;
    const Pose3& m = e.measurement;
    Information info = e.information;
    if (graph.dimension == 2) {
      out << ' ' << m.translation().x() << ' ' << m.translation().y() << ' ' << yawOf(m);
    } else {
      const Eigen::Quaterniond q(m.linear());
      out << ' ' << m.translation().transpose() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z()
          << ' ' << q.w();
      info = rotationVectorToQuaternion(info);
    }
    for (int r = 0; r < info.rows(); ++r) {
      for (int c = r; c < info.cols(); ++c) out << ' ' << info(r, c);
    }
    out << '\n';
  }
  if (!out) throw std::runtime_error("cannot write " + path);
}

std::vector<Pose3> readGroundTruth(const std::string& path, int dimension) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error("cannot read the ground truth " + path);
  std::vector<Pose3> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::vector<double> v;
    for (double x; in >> x;) v.push_back(x);
    const std::size_t values = dimension == 2 ? 3 : 7;
    if (v.size() != values && v.size() != values + 1) {
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": expected " +
                               std::to_string(values) + " values (or an id and them)");
    }
    const double* p = v.data() + (v.size() - values);
    poses.push_back(dimension == 2 ? planar(p[0], p[1], p[2])
                                   : spatial(p[0], p[1], p[2], p[3], p[4], p[5], p[6]));
  }
  return poses;
}

}  // namespace ccir_mapping::core::pose_graph
