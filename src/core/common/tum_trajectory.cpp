#include "ccir_mapping/core/common/tum_trajectory.h"

#include <cinttypes>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace ccir_mapping::core {

namespace {

constexpr double kQuaternionNormTolerance = 1e-3;

/// "<digits>[.<digits>]" to nanoseconds, exactly to the ninth decimal (further ones rounded).
bool parseStamp(const std::string& text, Stamp* stamp) {
  const auto dot = text.find('.');
  const std::string whole = text.substr(0, dot);
  const std::string fraction = dot == std::string::npos ? "" : text.substr(dot + 1);
  if (whole.empty() || whole.size() > 10 ||
      whole.find_first_not_of("0123456789") != std::string::npos ||
      fraction.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  Stamp nanoseconds = 0;
  for (std::size_t i = 0; i < 9; ++i) {
    nanoseconds = nanoseconds * 10 + (i < fraction.size() ? fraction[i] - '0' : 0);
  }
  if (fraction.size() > 9 && fraction[9] >= '5') ++nanoseconds;
  *stamp = std::stoll(whole) * 1000000000 + nanoseconds;
  return true;
}

}  // namespace

TumTrajectoryWriter::TumTrajectoryWriter(std::string path, const std::string& comment)
    : path_(std::move(path)), out_(path_) {
  if (!out_) throw std::runtime_error("cannot write " + path_);
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) out_ << "# " << line << '\n';
}

void TumTrajectoryWriter::add(Stamp stamp, const Pose3& pose) {
  if (stamp < 0) throw std::invalid_argument("a TUM trajectory's stamps are not negative");
  const Eigen::Vector3d& p = pose.translation();
  const Eigen::Quaterniond q(pose.linear());
  // The seconds from the integer nanoseconds: a double loses the last digits of an epoch stamp.
  char text[240];
  std::snprintf(
      text, sizeof(text), "%" PRId64 ".%09" PRId64 " %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n",
      stamp / 1000000000, stamp % 1000000000, p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
  out_ << text;
}

void TumTrajectoryWriter::close() {
  out_.close();
  if (!out_) throw std::runtime_error("could not write all of " + path_);
}

void TumTrajectoryWriter::write(const std::string& path, const std::string& comment,
                                const TumTrajectory& trajectory) {
  if (trajectory.stamps.size() != trajectory.poses.size()) {
    throw std::invalid_argument("a TUM trajectory needs one stamp per pose");
  }
  TumTrajectoryWriter writer(path, comment);
  for (std::size_t i = 0; i < trajectory.poses.size(); ++i) {
    writer.add(trajectory.stamps[i], trajectory.poses[i]);
  }
  writer.close();
}

TumTrajectory readTumTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  TumTrajectory trajectory;
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string stamp_text;
    double v[7];
    Stamp stamp = 0;
    std::string rest;
    bool ok = static_cast<bool>(fields >> stamp_text) && parseStamp(stamp_text, &stamp);
    for (double& value : v) ok = ok && static_cast<bool>(fields >> value) && std::isfinite(value);
    ok = ok && !(fields >> rest);
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (!ok || std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
      throw std::runtime_error(path + ":" + std::to_string(number) +
                               ": not 'stamp x y z qx qy qz qw' with a unit quaternion");
    }
    Pose3 pose = Pose3::Identity();
    pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    pose.linear() = q.normalized().toRotationMatrix();
    trajectory.stamps.push_back(stamp);
    trajectory.poses.push_back(pose);
  }
  if (in.bad()) throw std::runtime_error("could not read all of " + path);
  return trajectory;
}

}  // namespace ccir_mapping::core
