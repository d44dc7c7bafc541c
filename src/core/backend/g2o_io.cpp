#include "ccir_mapping/core/backend/g2o_io.h"

#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

namespace ccir_mapping::core::backend {
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
  std::map<int, Pose3> vertices;
  std::set<std::pair<int, int>> odometry_pairs;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    std::istringstream in(line);
    std::string tag;
    if (!(in >> tag) || tag[0] == '#') continue;
    try {
      const int dimension = tag == "VERTEX_SE2" || tag == "EDGE_SE2"             ? 2
                            : tag == "VERTEX_SE3:QUAT" || tag == "EDGE_SE3:QUAT" ? 3
                                                                                 : 0;
      if (dimension == 0) {
        if (tag == "FIX") continue;  // the first pose is always fixed
        throw std::invalid_argument("unsupported element '" + tag + "'");
      }
      if (graph.dimension != 0 && graph.dimension != dimension) {
        throw std::invalid_argument("mixes 2D and 3D elements");
      }
      graph.dimension = dimension;
      int id = 0;
      if (tag == "VERTEX_SE2") {
        double x, y, theta;
        if (!(in >> id >> x >> y >> theta)) throw std::invalid_argument("bad VERTEX_SE2");
        vertices[id] = planar(x, y, theta);
      } else if (tag == "VERTEX_SE3:QUAT") {
        double v[7];
        if (!(in >> id >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])) {
          throw std::invalid_argument("bad VERTEX_SE3:QUAT");
        }
        vertices[id] = spatial(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
      } else {
        PoseGraphEdge edge;
        if (!(in >> edge.from >> edge.to)) throw std::invalid_argument("bad edge ids");
        if (edge.from < 0 || edge.to < 0 || edge.from == edge.to) {
          throw std::invalid_argument("bad edge ids");
        }
        if (dimension == 2) {
          double x, y, theta;
          if (!(in >> x >> y >> theta)) throw std::invalid_argument("bad EDGE_SE2");
          edge.measurement = planar(x, y, theta);
          edge.information = readUpperTriangle(in, 3);
        } else {
          double v[7];
          if (!(in >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])) {
            throw std::invalid_argument("bad EDGE_SE3:QUAT");
          }
          edge.measurement = spatial(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
          edge.information = quaternionToRotationVector(readUpperTriangle(in, 6));
        }
        if (!edge.information.allFinite()) throw std::invalid_argument("non-finite information");
        const bool consecutive = edge.to == edge.from + 1;
        edge.loop = !(consecutive && odometry_pairs.insert({edge.from, edge.to}).second);
        graph.edges.push_back(edge);
      }
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + e.what());
    }
  }
  if (graph.dimension == 0) throw std::runtime_error(path + ": no pose graph in it");

  int count = vertices.empty() ? 0 : vertices.rbegin()->first + 1;
  for (const auto& e : graph.edges) count = std::max({count, e.from + 1, e.to + 1});
  graph.poses.assign(static_cast<std::size_t>(count), Pose3::Identity());
  if (!vertices.empty()) {
    if (static_cast<int>(vertices.size()) != count || vertices.begin()->first != 0) {
      throw std::runtime_error(path + ": vertex ids are not 0.." + std::to_string(count - 1));
    }
    for (const auto& [id, pose] : vertices) graph.poses[static_cast<std::size_t>(id)] = pose;
  } else {
    // No vertices: chain the odometry for the initial guess.
    std::vector<const PoseGraphEdge*> step(static_cast<std::size_t>(count), nullptr);
    for (const auto& e : graph.edges) {
      if (!e.loop) step[static_cast<std::size_t>(e.to)] = &e;
    }
    for (int i = 1; i < count; ++i) {
      const auto* e = step[static_cast<std::size_t>(i)];
      if (!e)
        throw std::runtime_error(path + ": no vertices and no odometry edge to " +
                                 std::to_string(i));
      graph.poses[static_cast<std::size_t>(i)] =
          graph.poses[static_cast<std::size_t>(i - 1)] * e->measurement;
    }
  }
  return graph;
}

void writeG2o(const PoseGraph& graph, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << std::setprecision(12);
  for (std::size_t i = 0; i < graph.poses.size(); ++i) {
    const Pose3& p = graph.poses[i];
    if (graph.dimension == 2) {
      out << "VERTEX_SE2 " << i << ' ' << p.translation().x() << ' ' << p.translation().y() << ' '
          << yawOf(p) << '\n';
    } else {
      const Eigen::Quaterniond q(p.linear());
      out << "VERTEX_SE3:QUAT " << i << ' ' << p.translation().transpose() << ' ' << q.x() << ' '
          << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
    }
  }
  for (const auto& e : graph.edges) {
    const Pose3& m = e.measurement;
    Information info = e.information;
    if (graph.dimension == 2) {
      out << "EDGE_SE2 " << e.from << ' ' << e.to << ' ' << m.translation().x() << ' '
          << m.translation().y() << ' ' << yawOf(m);
    } else {
      const Eigen::Quaterniond q(m.linear());
      out << "EDGE_SE3:QUAT " << e.from << ' ' << e.to << ' ' << m.translation().transpose() << ' '
          << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w();
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

}  // namespace ccir_mapping::core::backend
