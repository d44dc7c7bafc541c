// Trajectories in the TUM RGB-D format ("stamp x y z qx qy qz qw" per line, stamp in seconds,
// '#' comments), which evo, rpg_trajectory_evaluation and most SLAM tools read. Stamps are
// written with all nine decimals and read back to the nanosecond.
#pragma once

#include <fstream>
#include <string>
#include <vector>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core {

struct TumTrajectory {
  std::vector<Stamp> stamps;
  std::vector<Pose3> poses;
};

/// Writes one pose per line as it comes (a trajectory too long to hold, e.g. ground truth at the
/// odometry rate). Every error surfaces as std::runtime_error naming the file.
class TumTrajectoryWriter {
 public:
  /// Creates (truncates) `path`; `comment` (may be empty) is written first, each line after '#'.
  TumTrajectoryWriter(std::string path, const std::string& comment);
  /// Throws std::invalid_argument for a negative stamp.
  void add(Stamp stamp, const Pose3& pose);
  /// Flushes and checks that everything reached the file.
  void close();

  /// A whole trajectory at once; stamps and poses have the same length.
  static void write(const std::string& path, const std::string& comment, const TumTrajectory& t);

 private:
  std::string path_;
  std::ofstream out_;
};

/// Throws std::runtime_error naming the file (and the line) when it cannot be read or a line is
/// not eight finite numbers with a non-negative stamp and a unit quaternion (within 1e-3).
TumTrajectory readTumTrajectory(const std::string& path);

}  // namespace ccir_mapping::core
