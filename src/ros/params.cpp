#include "ccir_mapping/ros/params.h"

#include <cmath>

#include "ccir_mapping/core/common/param_check.h"

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

// Reads a string field of one list entry; records an error naming "list[i].field".
bool readEntryString(ParamReader& reader, const XmlRpc::XmlRpcValue& entry, const std::string& name,
                     const std::string& field, std::string& out) {
  XmlRpc::XmlRpcValue copy = entry;
  if (!copy.hasMember(field) || copy[field].getType() != XmlRpc::XmlRpcValue::TypeString) {
    reader.addError(name + "." + field + " is missing or not a string");
    return false;
  }
  out = static_cast<std::string>(copy[field]);
  return true;
}

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

}  // namespace

void load(ParamReader& reader, PreprocessorSettings& config) {
  load(reader, config.frames);
  reader.read("odom_source", config.odom_source);
  if (config.odom_source != "topic" && config.odom_source != "tf") {
    reader.addError(core::notOneOf("odom_source", config.odom_source, "topic | tf"));
  }
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
  reader.read("keyframe_distance_m", p.keyframe_distance_m);
  reader.read("keyframe_rotation_deg", p.keyframe_rotation_deg);
  reader.read("odom_tolerance_s", p.odom_tolerance_s);
  reader.addErrors(p.validate());
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
  reader.read("own_loop_gate_m_per_m", p.own_loop_gate_m_per_m);
  reader.read("own_loop_gate_rad_per_m", p.own_loop_gate_rad_per_m);
  reader.read("min_inliers", p.min_inliers);
  reader.read("max_fitness_m2", p.max_fitness_m2);
  reader.read("min_overlap", p.min_overlap);
  reader.read("overlap_distance_m", p.overlap_distance_m);
  reader.read("max_free_space_violation", p.max_free_space_violation);
  reader.read("free_space_margin_m", p.free_space_margin_m);
  reader.addErrors(p.validate());
}

void load(ParamReader& reader, BackendSettings& config) {
  load(reader, config.frames);
  reader.read("publish_tf", config.publish_tf);
  auto& p = config.core;
  reader.readChoice("robust_kernel", p.robust_kernel, core::backend::parseRobustKernel,
                    core::backend::kRobustKernelChoices, &core::backend::toString);
  reader.read("switch_prior_sigma", p.switch_prior_sigma);
  reader.read("optimize_period_s", p.optimize_period_s);
  reader.read("max_solve_time_s", p.max_solve_time_s);
  reader.read("max_iterations", p.max_iterations);
  reader.read("odom_sigma_m_per_m", p.odom_sigma_m_per_m);
  reader.read("odom_sigma_rad_per_m", p.odom_sigma_rad_per_m);
  reader.read("min_team_inliers", p.min_team_inliers);
  reader.read("team_inlier_margin", p.team_inlier_margin);
  reader.addErrors(p.validate());
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
  reader.read("rebuild_shift_m", p.rebuild_shift_m);
  reader.read("rebuild_rotation_deg", p.rebuild_rotation_deg);
  reader.read("entropy_box_half_width_m", p.entropy_box_half_width_m);
  reader.read("entropy_box_min_z_m", p.entropy_box_min_z_m);
  reader.read("entropy_box_max_z_m", p.entropy_box_max_z_m);
  reader.read("publish_period_s", p.publish_period_s);
  reader.read("map_path", config.map_path);
  reader.read("save_on_shutdown", config.save_on_shutdown);
  reader.addErrors(p.validate());
}

void load(ParamReader& reader, BrokerSettings& config) {
  load(reader, config.frames);
  auto& p = config.core;
  reader.readChoice("mode", p.mode, core::routing::parseRoutingMode,
                    core::routing::kRoutingModeChoices, &core::routing::toString);
  reader.read("loop_closure_weight", p.loop_closure_weight);
  reader.read("unknown_transform_factor", p.unknown_transform_factor);
  reader.read("budget_bytes_per_s", p.budget_bytes_per_s);
  reader.read("offer_period_s", p.offer_period_s);
  reader.read("fixed_rate_every_n", p.fixed_rate_every_n);
  reader.read("stats_period_s", p.stats_period_s);
  reader.addErrors(p.validate());
}

void load(ParamReader& reader, BridgeSettings& config) {
  load(reader, config.frames);
  auto& p = config.core;
  reader.read("listen_port", p.listen_port);
  reader.read("budget_bytes_per_s", p.budget_bytes_per_s);
  reader.read("burst_bytes", p.burst_bytes);
  reader.read("fragment_bytes", p.fragment_bytes);
  reader.read("stats_period_s", p.stats_period_s);

  forEachEntry(reader, "peers", [&](const std::string& name, const XmlRpc::XmlRpcValue& entry) {
    core::transport::PeerConfig peer;
    readEntryString(reader, entry, name, "name", peer.name);
    readEntryString(reader, entry, name, "host", peer.host);
    XmlRpc::XmlRpcValue copy = entry;
    if (copy.hasMember("port") && copy["port"].getType() == XmlRpc::XmlRpcValue::TypeInt) {
      peer.port = static_cast<int>(copy["port"]);
    } else {
      reader.addError(name + ".port is missing or not an integer");
    }
    p.peers.push_back(peer);
  });

  // Without a `topics` list, every outbox topic of the protocol is forwarded.
  if (!reader.raw("topics")) {
    using core::transport::Priority;
    p.topics = {{"outbox/features", Priority::kControl},
                {"outbox/offers", Priority::kControl},
                {"outbox/requests", Priority::kControl},
                {"outbox/receipts", Priority::kControl},
                {"outbox/scans", Priority::kBulk}};
  }
  forEachEntry(reader, "topics", [&](const std::string& name, const XmlRpc::XmlRpcValue& entry) {
    core::transport::ForwardedTopic topic;
    readEntryString(reader, entry, name, "topic", topic.topic);
    std::string priority = "control";
    XmlRpc::XmlRpcValue copy = entry;
    if (copy.hasMember("priority")) readEntryString(reader, entry, name, "priority", priority);
    if (const auto parsed = core::transport::parsePriority(priority)) {
      topic.priority = *parsed;
    } else {
      reader.addError(
          core::notOneOf(name + ".priority", priority, core::transport::kPriorityChoices));
    }
    p.topics.push_back(topic);
  });
  reader.addErrors(p.validate(config.frames.robot_name));
}

}  // namespace ccir_mapping::ros_params
