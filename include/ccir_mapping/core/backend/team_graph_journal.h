// Every input a robot's team graph took, kept in DIR/team_graph_inputs as it arrives (one line
// each), so that a robot restarted after a crash rebuilds the same graph by handing them to a
// new TeamGraphWorker: its own keyframes with their odometry, its teammates' keyframes and
// every loop closure, as they were routed (team_graph.g2o is the graph's result, not what it
// was made of). Numbers are written to 17 digits, so a replay is exact. A line the crash cut
// short is left out; any other unreadable line is an error.
#pragma once

#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "ccir_mapping/core/backend/team_graph_worker.h"

namespace ccir_mapping::core::backend {

class TeamGraphJournal {
 public:
  using Input = TeamGraphWorker::Input;
  static constexpr const char* kFileName = "team_graph_inputs";

  /// The journal of robot `robot` in DIR (created). With `resume`, what the file holds is read
  /// (takeSaved()) and kept; without, a new mission starts an empty file, and the last one's is
  /// kept beside as DIR/team_graph_inputs.previous (a restart that forgot resume can be undone
  /// by renaming it back). Throws
  /// std::runtime_error naming the file (and line) when it cannot be read or written, or holds
  /// another robot's inputs.
  TeamGraphJournal(const std::string& dir, const std::string& robot, bool resume);
  ~TeamGraphJournal();
  TeamGraphJournal(const TeamGraphJournal&) = delete;
  TeamGraphJournal& operator=(const TeamGraphJournal&) = delete;

  const std::string& path() const { return path_; }
  /// The inputs read when resuming, in the order they arrived; taken once.
  std::vector<Input> takeSaved() { return std::move(saved_); }

  /// Appends one input (from any thread) and hands it to the operating system, so that a
  /// process killed right after has it on file. Throws std::runtime_error naming the file.
  void append(const Input& input);

  /// One input as a line without its newline; parse() reads it back (nullopt if it is not one).
  static std::string format(const Input& input);
  static std::optional<Input> parse(const std::string& line);

 private:
  std::string path_;
  std::vector<Input> saved_;
  std::mutex mutex_;  // guards file_
  std::FILE* file_ = nullptr;
};

}  // namespace ccir_mapping::core::backend
