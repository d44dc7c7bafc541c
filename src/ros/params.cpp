#include "ccir_mapping/ros/params.h"

#include <cmath>
#include <cstdlib>
#include <set>
#include <type_traits>

#include "ccir_mapping/core/common/param_check.h"
#include "ccir_mapping/ros/topics.h"

namespace ccir_mapping::ros_params {
namespace {

void load(ParamReader& reader, RobotFrames& frames) {
  reader.read("robot_name", frames.robot_name);
  if (!core::isValidRobotName(frames.robot_name)) {
    core::ParamCheck check;
    check.robotName("robot_name", frames.robot_name);
    reader.addErrors(check.errors());
  }
  frames.map_frame = frames.robot_name + "/map";
  frames.odom_frame = frames.robot_name + "/odom";
  frames.base_frame = frames.robot_name + "/base_link";
  reader.read("map_frame", frames.map_frame);
  reader.read("odom_frame", frames.odom_frame);
  reader.read("base_frame", frames.base_frame);
  for (const auto& [key, frame] :
       {std::pair{"map_frame", &frames.map_frame}, std::pair{"odom_frame", &frames.odom_frame},
        std::pair{"base_frame", &frames.base_frame}}) {
    if (frame->empty() || frame->front() == '/') {
      reader.addError(std::string(key) + " = '" + *frame +
                      "' is not allowed: allowed a non-empty frame id without a leading '/'");
    }
  }
}

// One dictionary of a list parameter: typed fields, with errors naming "list[i].field"; fields
// no one reads are reported as unknown when it goes (a misspelt option must not pass silently).
class EntryReader {
 public:
  EntryReader(ParamReader& reader, std::string name, const XmlRpc::XmlRpcValue& entry)
      : reader_(reader), name_(std::move(name)), entry_(entry) {}
  EntryReader(const EntryReader&) = delete;
  EntryReader& operator=(const EntryReader&) = delete;
  ~EntryReader() {
    for (const auto& [field, value] : entry_) {
      if (!read_.count(field)) reader_.addError(name_ + "." + field + " is not a known field");
    }
  }

  template <class T>
  void read(const std::string& field, T& out, bool required = false) {
    read_.insert(field);
    if (!entry_.hasMember(field)) {
      if (required) reader_.addError(name_ + "." + field + " is missing");
      return;
    }
    XmlRpc::XmlRpcValue& value = entry_[field];
    const auto type = value.getType();
    if constexpr (std::is_same_v<T, std::string>) {
      if (type == XmlRpc::XmlRpcValue::TypeString)
        return void(out = static_cast<std::string>(value));
    } else if constexpr (std::is_same_v<T, bool>) {
      if (type == XmlRpc::XmlRpcValue::TypeBoolean) return void(out = static_cast<bool>(value));
    } else if constexpr (std::is_floating_point_v<T>) {
      if (type == XmlRpc::XmlRpcValue::TypeDouble) return void(out = static_cast<double>(value));
      if (type == XmlRpc::XmlRpcValue::TypeInt) return void(out = static_cast<int>(value));
    } else {
      if (type == XmlRpc::XmlRpcValue::TypeInt) return void(out = static_cast<int>(value));
    }
    reader_.addError(name_ + "." + field + " has the wrong type");
  }

 private:
  ParamReader& reader_;
  std::string name_;
  XmlRpc::XmlRpcValue entry_;  // a copy: XmlRpcValue's accessors are not const
  std::set<std::string> read_;
};

// Iterates a list parameter whose entries are structs; records an error if it is not one.
template <class Fn>
void forEachEntry(ParamReader& reader, const std::string& key, Fn fn) {
  const XmlRpc::XmlRpcValue* list = reader.raw(key);
  if (!list) return;
  if (list->getType() != XmlRpc::XmlRpcValue::TypeArray) {
    reader.addError(key + " has the wrong type: expected a list");
    return;
  }
  for (int i = 0; i < list->size(); ++i) {
    const XmlRpc::XmlRpcValue& entry = (*list)[i];
    const std::string name = key + "[" + std::to_string(i) + "]";
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      reader.addError(name + " has the wrong type: expected a dictionary");
      continue;
    }
    fn(name, entry);
  }
}

/// `name` in $ROS_HOME (~/.ros without it), where ROS tools write by default.
std::string rosHomeFile(const std::string& name) {
  const char* ros_home = std::getenv("ROS_HOME");
  const char* home = std::getenv("HOME");
  return (ros_home ? std::string(ros_home) : std::string(home ? home : ".") + "/.ros") + "/" + name;
}

/// save_dir and resume, and save_on_shutdown and save_period_s for a nodelet that `writes_files`.
void load(ParamReader& reader, const std::string& robot_name, SaveSettings& save,
          bool writes_files = true) {
  reader.read("save_dir", save.dir);
  reader.read("resume", save.resume);
  if (writes_files) {
    reader.read("save_on_shutdown", save.on_shutdown);
    reader.read("save_period_s", save.period_s);
    core::ParamCheck period;
    period.inRange("save_period_s", save.period_s, 0.0, 86400.0);
    reader.addErrors(period.errors());
  }
  if (save.dir.empty()) save.dir = rosHomeFile("ccir_mapping/" + robot_name);
}

}  // namespace

void load(ParamReader& reader, PreprocessorSettings& config) {
  load(reader, config.frames);
  reader.read("odom_source", config.odom_source);
  if (config.odom_source != "topic" && config.odom_source != "tf" &&
      config.odom_source != "lidar") {
    reader.addError(core::notOneOf("odom_source", config.odom_source, "topic | tf | lidar"));
  }
  reader.read("scan_queue_size", config.scan_queue_size);
  core::ParamCheck queue;
  queue.inRange("scan_queue_size", config.scan_queue_size, 1, 1000);
  reader.addErrors(queue.errors());
  auto& p = config.core;
  reader.read("min_range_m", p.min_range_m);
  reader.read("max_range_m", p.max_range_m);
  reader.read("voxel_leaf_m", p.voxel_leaf_m);
  reader.read("normal_radius_m", p.normal_radius_m);
  reader.readChoice("drop_horizontal", p.drop_horizontal, core::preprocess::parseHorizontalFilter,
                    core::preprocess::kHorizontalFilterChoices, &core::preprocess::toString);
  reader.read("horizontal_normal_z", p.horizontal_normal_z);
  reader.read("slice_mode", p.slice_mode);
  reader.read("slice_min_z_m", p.slice_min_z_m);
  reader.read("slice_max_z_m", p.slice_max_z_m);
  reader.read("threads", p.threads);
  reader.read("min_points", p.min_points);
  reader.read("max_points", p.max_points);
  reader.read("keyframe_distance_m", p.keyframe_distance_m);
  reader.read("keyframe_rotation_deg", p.keyframe_rotation_deg);
  reader.read("odom_tolerance_s", p.odom_tolerance_s);
  reader.addErrors(p.validate());
  auto& l = config.lidar_odometry;
  reader.read("lidar_voxel_m", l.voxel_m);
  reader.read("lidar_min_range_m", l.min_range_m);
  reader.read("lidar_local_map_scans", l.local_map_scans);
  reader.read("lidar_local_map_step_m", l.local_map_step_m);
  reader.read("lidar_local_map_step_deg", l.local_map_step_deg);
  reader.read("lidar_max_correspondence_m", l.max_correspondence_m);
  reader.read("lidar_max_iterations", l.max_iterations);
  reader.read("lidar_max_fitness_m2", l.max_fitness_m2);
  reader.addErrors(l.validate());
  load(reader, config.frames.robot_name, config.save, /*writes_files=*/false);
  if (config.save.resume && config.odom_source == "lidar") {
    // Teammates and the resumed team graph chain the new keyframes to the old by odometry.
    reader.addError(
        "resume = true needs odometry that outlives the manager (odom_source topic "
        "or tf): lidar odometry starts again at the origin");
  }
}

void load(ParamReader& reader, MatcherSettings& config) {
  load(reader, config.frames);
  auto& p = config.core;
  reader.readChoice("method", p.method, core::place_recognition::parseMatchMethod,
                    core::place_recognition::kMatchMethodChoices,
                    &core::place_recognition::toString);
  reader.read("model_dir", p.model_dir);
  reader.read("min_correspondences", p.min_correspondences);
  reader.read("loop_exclusion_s", p.loop_exclusion_s);
  reader.read("max_candidates", p.max_candidates);
  reader.read("min_place_probability", p.min_place_probability);
  reader.read("new_place_prior", p.fabmap.new_place_prior);
  reader.read("motion_prior_weight", p.fabmap.motion_prior_weight);
  reader.read("scan_context_max_range_m", p.scan_context.max_range_m);
  reader.read("scan_context_ring_key_candidates", p.scan_context.ring_key_candidates);
  reader.readChoice(
      "hgmm_candidates", p.hgmm.candidates, core::place_recognition::parseMixtureCandidates,
      core::place_recognition::kMixtureCandidatesChoices, &core::place_recognition::toString);
  reader.read("hgmm_max_depth", p.hgmm.model.max_depth);
  reader.read("hgmm_min_similarity", p.hgmm.registration.min_similarity);
  reader.read("complete_places", p.complete_places);
  reader.read("own_loop_gate_m_per_m", p.own_loop_gate_m_per_m);
  reader.read("own_loop_gate_rad_per_m", p.own_loop_gate_rad_per_m);
  reader.read("search_reach_m", p.search.reach_m);
  reader.read("search_max_drift_m", p.search.max_drift_m);
  reader.read("gated_candidates", p.search.gated_candidates);
  reader.read("prior_free_verifications_per_s", p.search.prior_free_verifications_per_s);
  reader.read("prior_free_horizon_s", p.search.prior_free_horizon_s);
  auto& v = p.verification;
  reader.read("min_inliers", v.min_inliers);
  reader.read("max_fitness_m2", v.max_fitness_m2);
  reader.read("min_overlap", v.min_overlap);
  reader.read("overlap_distance_m", v.overlap_distance_m);
  reader.read("max_free_space_violation", v.max_free_space_violation);
  reader.read("free_space_margin_m", v.free_space_margin_m);
  reader.read("mixture_overlap_distance_m", v.mixture_overlap_distance_m);
  reader.read("mixture_free_space_margin_m", v.mixture_free_space_margin_m);
  reader.addErrors(p.validate());
}

void load(ParamReader& reader, BackendSettings& config) {
  load(reader, config.frames);
  reader.read("publish_tf", config.publish_tf);
  auto& p = config.core;
  reader.readChoice("robust_kernel", p.robust_kernel, core::pose_graph::parseRobustKernel,
                    core::pose_graph::kRobustKernelChoices, &core::pose_graph::toString);
  reader.read("switch_prior_sigma", p.switch_prior_sigma);
  reader.read("optimize_period_s", p.optimize_period_s);
  reader.read("solve_window_keyframes", p.solve_window_keyframes);
  reader.read("full_solve_period_s", p.full_solve_period_s);
  reader.read("revisit_loop_error_m", p.revisit_loop_error_m);
  reader.read("uncertainty_period_s", p.uncertainty_period_s);
  reader.read("max_solve_time_s", p.max_solve_time_s);
  reader.read("max_iterations", p.max_iterations);
  reader.read("odom_sigma_m_per_m", p.odometry.sigma_m_per_m);
  reader.read("odom_sigma_rad_per_m", p.odometry.sigma_rad_per_m);
  reader.read("odom_sigma_rad_per_rad", p.odometry.sigma_rad_per_rad);
  reader.read("min_team_inliers", p.min_team_inliers);
  reader.read("team_inlier_margin", p.team_inlier_margin);
  reader.read("team_graph", p.team_graph);
  reader.read("team_disagreement_m", p.team_disagreement_m);
  reader.read("team_disagreement_deg", p.team_disagreement_deg);
  reader.addErrors(p.validate());
  load(reader, config.frames.robot_name, config.save);
}

void load(ParamReader& reader, MapperSettings& config) {
  load(reader, config.frames);
  auto& p = config.core;
  reader.read("resolution_m", p.resolution_m);
  reader.read("max_insert_range_m", p.max_insert_range_m);
  reader.read("occupancy_clamp_min", p.occupancy_clamp_min);
  reader.read("occupancy_clamp_max", p.occupancy_clamp_max);
  reader.read("csqmi_sigma_m", p.csqmi_sigma_m);
  reader.read("simulated_azimuth_step_deg", p.simulated_azimuth_step_deg);
  reader.read("scan_beam_step", p.scan_beam_step);
  reader.read("submap_scans", p.submap_scans);
  reader.read("reanchor_shift_m", p.reanchor_shift_m);
  reader.read("reanchor_rotation_deg", p.reanchor_rotation_deg);
  reader.read("reanchor_wait_s_per_mvoxel_visited", p.reanchor_wait_s_per_mvoxel_visited);
  reader.read("submap_window_scans", p.submap_window_scans);
  reader.read("entropy_box_half_width_m", p.entropy_box_half_width_m);
  reader.read("entropy_box_min_z_m", p.entropy_box_min_z_m);
  reader.read("entropy_box_max_z_m", p.entropy_box_max_z_m);
  reader.read("publish_period_s", p.publish_period_s);
  reader.addErrors(p.validate());
  load(reader, config.frames.robot_name, config.save);
}

void load(ParamReader& reader, BrokerSettings& config) {
  load(reader, config.frames);
  for (const auto& [key, name] :
       {std::pair{"mapper", &config.mapper}, std::pair{"bridge", &config.bridge}}) {
    reader.read(key, *name);
    if (name->empty()) {
      reader.addError(std::string(key) + " = '' is not allowed: allowed the name of a nodelet");
    }
  }
  auto& p = config.core;
  reader.readChoice("mode", p.mode, core::routing::parseRoutingMode,
                    core::routing::kRoutingModeChoices, &core::routing::toString);
  reader.read("loop_closure_weight", p.loop_closure_weight);
  reader.read("unknown_transform_factor", p.unknown_transform_factor);
  reader.read("offer_period_s", p.offer_period_s);
  reader.read("max_kept_scans", p.max_kept_scans);
  reader.read("receipt_timeout_s", p.receipt_timeout_s);
  reader.read("max_offer_scans", p.max_offer_scans);
  reader.read("min_novelty", p.min_novelty);
  reader.readChoice("scan_encoding", p.scan_encoding, core::routing::parseScanEncoding,
                    core::routing::kScanEncodingChoices, &core::routing::toString);
  reader.read("gmm_max_bytes", p.gmm_max_bytes);
  reader.read("fixed_rate_every_n", p.fixed_rate_every_n);
  reader.read("stats_period_s", p.stats_period_s);
  reader.addErrors(p.validate());
}

void load(ParamReader& reader, BridgeSettings& config) {
  load(reader, config.frames);
  auto& p = config.core;
  reader.read("listen_port", p.listen_port);
  reader.read("listen_address", p.listen_address);
  reader.read("team_key", p.team_key);
  reader.read("budget_bytes_per_s", p.budget_bytes_per_s);
  reader.read("total_budget_bytes_per_s", p.total_budget_bytes_per_s);
  reader.read("max_message_bytes", p.max_message_bytes);
  reader.read("reconnect_min_s", p.reconnect_min_s);
  reader.read("reconnect_max_s", p.reconnect_max_s);
  reader.read("peer_timeout_s", p.peer_timeout_s);
  reader.read("burst_bytes", p.burst_bytes);
  reader.read("fragment_bytes", p.fragment_bytes);
  reader.read("stats_period_s", p.stats_period_s);

  forEachEntry(reader, "peers", [&](const std::string& name, const XmlRpc::XmlRpcValue& entry) {
    core::transport::PeerConfig peer;
    EntryReader fields(reader, name, entry);
    fields.read("name", peer.name, true);
    fields.read("host", peer.host, true);
    fields.read("port", peer.port, true);
    p.peers.push_back(peer);
  });

  // Without a `topics` list, every outbox topic of the protocol is forwarded.
  if (!reader.raw("topics")) {
    using core::transport::Priority;
    const char* names[] = {topics::kOutboxFeatures,     topics::kOutboxOffers,
                           topics::kOutboxRequests,     topics::kOutboxReceipts,
                           topics::kOutboxLoopClosures, topics::kOutboxScans};
    for (const char* name : names) p.topics.emplace_back().topic = name;
    p.topics.back().policy.priority = Priority::kBulk;
  }
  forEachEntry(reader, "topics", [&](const std::string& name, const XmlRpc::XmlRpcValue& entry) {
    core::transport::ForwardedTopic topic;
    EntryReader fields(reader, name, entry);
    fields.read("topic", topic.topic, true);
    std::string priority = "control";
    std::string queue = "fifo";
    int max_queued = static_cast<int>(topic.policy.max_queued);
    fields.read("priority", priority);
    fields.read("queue", queue);
    fields.read("max_queued", max_queued);
    fields.read("max_age_s", topic.policy.max_age_s);
    fields.read("reliable", topic.reliable);
    fields.read("compress", topic.compress);
    if (const auto parsed = core::transport::parsePriority(priority)) {
      topic.policy.priority = *parsed;
    } else {
      reader.addError(
          core::notOneOf(name + ".priority", priority, core::transport::kPriorityChoices));
    }
    if (const auto parsed = core::transport::parseQueuePolicy(queue)) {
      topic.policy.queue = *parsed;
    } else {
      reader.addError(core::notOneOf(name + ".queue", queue, core::transport::kQueuePolicyChoices));
    }
    topic.policy.max_queued = static_cast<std::size_t>(std::max(0, max_queued));
    p.topics.push_back(topic);
  });
  reader.addErrors(p.validate(config.frames.robot_name));
}

}  // namespace ccir_mapping::ros_params
