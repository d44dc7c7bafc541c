#include "ccir_mapping/core/backend/team_graph_journal.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace ccir_mapping::core::backend {

using pose_graph::LoopClosureData;

namespace {

constexpr const char* kHeader = "# ccir_mapping team graph inputs of ";

bool isName(const std::string& name) {
  return !name.empty() && name.find_first_of(" \t\r\n") == std::string::npos;
}

void put(std::ostringstream& out, double value) {
  char text[32];
  std::snprintf(text, sizeof(text), " %.17g", value);
  out << text;
}

/// The 3 x 4 rows of the pose: exact, unlike a quaternion.
void put(std::ostringstream& out, const Pose3& pose) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) put(out, pose.matrix()(r, c));
}

bool get(std::istringstream& in, double* value) {
  std::string token;
  if (!(in >> token)) return false;
  char* end = nullptr;
  *value = std::strtod(token.c_str(), &end);
  return end == token.c_str() + token.size();
}

bool get(std::istringstream& in, Pose3* pose) {
  pose->setIdentity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (!get(in, &pose->matrix()(r, c))) return false;
  return isValidPose(*pose);
}

bool get(std::istringstream& in, std::optional<Pose3>* pose) {
  std::string present;
  if (!(in >> present) || (present != "+" && present != "-")) return false;
  if (present == "-") return true;
  Pose3 value;
  if (!get(in, &value)) return false;
  *pose = value;
  return true;
}

template <class Id>
bool getId(std::istringstream& in, Id* id) {
  std::string token;
  if (!(in >> token) || token.empty() || token.size() > 19 ||
      token.find_first_not_of(std::is_signed_v<Id> ? "-0123456789" : "0123456789") !=
          std::string::npos) {
    return false;
  }
  *id = static_cast<Id>(std::is_signed_v<Id> ? std::stoll(token) : std::stoull(token));
  return true;
}

}  // namespace

std::string TeamGraphJournal::format(const Input& input) {
  std::ostringstream out;
  if (const auto* own = std::get_if<TeamGraphWorker::OwnKeyframe>(&input)) {
    out << "K " << own->robot << ' ' << own->id << ' ' << own->stamp;
    put(out, own->odom_pose.value_or(Pose3::Identity()));
  } else if (const auto* peer = std::get_if<TeamGraphWorker::PeerKeyframe>(&input)) {
    out << "P " << peer->robot << ' ' << peer->id;
    put(out, peer->pose.value_or(Pose3::Identity()));
  } else {
    const auto& loop = std::get<LoopClosureData>(input);
    out << "L " << loop.robot_from << ' ' << loop.keyframe_from << ' ' << loop.robot_to << ' '
        << loop.keyframe_to;
    put(out, loop.relative);
    for (int i = 0; i < 36; ++i) put(out, loop.covariance(i / 6, i % 6));
    for (const auto& pose : {loop.odom_pose_from, loop.odom_pose_to}) {
      out << (pose ? " +" : " -");
      if (pose) put(out, *pose);
    }
    put(out, loop.match_score);
    put(out, loop.new_place_probability);
    put(out, loop.fitness_m2);
    out << ' ' << loop.inliers << ' ' << (isName(loop.method) ? loop.method : "-");
  }
  return out.str();
}

std::optional<TeamGraphJournal::Input> TeamGraphJournal::parse(const std::string& line) try {
  std::istringstream in(line);
  std::string kind, rest;
  in >> kind;
  std::optional<Input> input;
  if (kind == "K") {
    TeamGraphWorker::OwnKeyframe own;
    Pose3 pose;
    if (in >> own.robot && getId(in, &own.id) && getId(in, &own.stamp) && get(in, &pose)) {
      own.odom_pose = pose;
      input = own;
    }
  } else if (kind == "P") {
    TeamGraphWorker::PeerKeyframe peer;
    Pose3 pose;
    if (in >> peer.robot && getId(in, &peer.id) && get(in, &pose)) {
      peer.pose = pose;
      input = peer;
    }
  } else if (kind == "L") {
    LoopClosureData loop;
    bool ok = in >> loop.robot_from && getId(in, &loop.keyframe_from) && in >> loop.robot_to &&
              getId(in, &loop.keyframe_to) && get(in, &loop.relative);
    for (int i = 0; ok && i < 36; ++i) ok = get(in, &loop.covariance(i / 6, i % 6));
    ok = ok && get(in, &loop.odom_pose_from) && get(in, &loop.odom_pose_to) &&
         get(in, &loop.match_score) && get(in, &loop.new_place_probability) &&
         get(in, &loop.fitness_m2) && in >> loop.inliers && in >> loop.method;
    if (ok && loop.method == "-") loop.method.clear();
    if (ok && !pose_graph::loopClosureProblem(loop)) input = loop;
  }
  if (in >> rest) return std::nullopt;  // more than an input
  return input;
} catch (const std::exception&) {  // a number out of range
  return std::nullopt;
}

TeamGraphJournal::TeamGraphJournal(const std::string& dir, const std::string& robot, bool resume)
    : path_(dir + "/" + kFileName) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create " + dir + ": " + error.message());
  const std::string header = kHeader + robot;
  if (resume && std::filesystem::exists(path_)) {
    std::ifstream in(path_);
    if (!in) throw std::runtime_error("cannot read " + path_);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // A line without its newline is one a crash cut short: dropped, from the file too.
    const auto end = text.find_last_of('\n');
    text.erase(end == std::string::npos ? 0 : end + 1);
    std::filesystem::resize_file(path_, text.size(), error);
    if (error) throw std::runtime_error("cannot write " + path_ + ": " + error.message());
    std::istringstream lines(text);
    std::string line;
    if (std::getline(lines, line) && line != header) {
      throw std::runtime_error(path_ + " is not the team graph inputs of " + robot);
    }
    for (int number = 2; std::getline(lines, line); ++number) {
      auto input = parse(line);
      if (!input) {
        throw std::runtime_error(path_ + ":" + std::to_string(number) +
                                 ": not a team graph input (delete the file to start anew)");
      }
      saved_.push_back(std::move(*input));
    }
  }
  const bool keep = resume && std::filesystem::exists(path_) && std::filesystem::file_size(path_);
  if (!resume && std::filesystem::exists(path_)) {
    std::filesystem::rename(path_, path_ + ".previous", error);
    if (error) throw std::runtime_error("cannot write " + path_ + ": " + error.message());
  }
  file_ = std::fopen(path_.c_str(), keep ? "a" : "w");
  if (!file_) throw std::runtime_error("cannot write " + path_);
  if (!keep && (std::fprintf(file_, "%s\n", header.c_str()) < 0 || std::fflush(file_) != 0)) {
    std::fclose(file_);  // no destructor after a throwing constructor
    throw std::runtime_error("cannot write " + path_);
  }
}

TeamGraphJournal::~TeamGraphJournal() {
  if (file_) std::fclose(file_);
}

void TeamGraphJournal::append(const Input& input) {
  const bool named = std::visit(
      [](const auto& in) {
        if constexpr (std::is_same_v<std::decay_t<decltype(in)>, LoopClosureData>) {
          return isName(in.robot_from) && isName(in.robot_to);
        } else {
          return isName(in.robot);
        }
      },
      input);
  if (!named) throw std::invalid_argument("a robot name with white space cannot be kept");
  const std::string line = format(input);
  std::lock_guard<std::mutex> lock(mutex_);
  if (std::fprintf(file_, "%s\n", line.c_str()) < 0 || std::fflush(file_) != 0) {
    throw std::runtime_error("cannot write " + path_);
  }
}

}  // namespace ccir_mapping::core::backend
