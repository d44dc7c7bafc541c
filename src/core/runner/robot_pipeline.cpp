#include "ccir_mapping/core/runner/robot_pipeline.h"

#include <pcl/common/io.h>

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/routing/scan_encoding.h"

namespace ccir_mapping::core::runner {

namespace pr = place_recognition;

namespace {

using KeyframeCloud = pcl::PointCloud<pcl::PointXYZINormal>;

std::shared_ptr<const information::Cloud> xyzOf(const KeyframeCloud& cloud) {
  auto xyz = std::make_shared<information::Cloud>();
  pcl::copyPointCloud(cloud, *xyz);
  return xyz;
}

}  // namespace

template <class F>
decltype(auto) RobotPipeline::measured(const char* stage, F&& work) {
  struct Clock {
    RobotPipeline& self;
    const char* stage;
    double start = threadCpuSeconds();
    ~Clock() { self.addCpu(stage, threadCpuSeconds() - start); }
  } clock{*this, stage};
  return work();
}

std::function<void(const char*, const std::function<void()>&)> RobotPipeline::meter() {
  return [this](const char* stage, const std::function<void()>& work) { measured(stage, work); };
}

void RobotPipeline::addCpu(const char* stage, double seconds) {
  std::lock_guard<std::mutex> lock(cpu_mutex_);
  stage_cpu_[stage] += seconds;
}

std::map<std::string, double> RobotPipeline::stageCpu() const {
  std::lock_guard<std::mutex> lock(cpu_mutex_);
  return stage_cpu_;
}

bool RobotPipeline::Timer::due(double now_s) {
  if (now_s < next_s) return false;
  while (next_s <= now_s) next_s += period_s;
  return true;
}

RobotPipeline::RobotPipeline(std::string name, std::vector<std::string> peers,
                             const RunnerParams& params,
                             std::shared_ptr<const pr::PlaceModel> model, double start_s,
                             double phase)
    : name_(std::move(name)),
      matcher_(name_, params.matcher, std::move(model), {meter()}),
      map_(name_, params.mapper, {meter()}),
      broker_(name_, std::move(peers), params.broker, params.mapper,
              [](const routing::ControlMessage& m) {
                return std::visit([](const auto& c) { return serializedBytes(TeamMessage(c)); }, m);
              }),
      offers_{params.broker.offer_period_s, start_s + phase * params.broker.offer_period_s},
      optimisation_{params.backend.optimize_period_s,
                    start_s + phase * params.backend.optimize_period_s},
      map_update_{params.mapper.publish_period_s,
                  start_s + phase * params.mapper.publish_period_s} {
  broker_.setMap(map_.map());
  backend::BackendStage::Hooks hooks;
  hooks.run = meter();
  hooks.optimized = [this](const backend::BackendStage::Output& out) { route(out); };
  hooks.refused = [this](const backend::BackendStage::Refusal& r) { refuse(r.notice.kind); };
  backend_ = std::make_unique<backend::BackendStage>(name_, params.backend, hooks,
                                                     backend::BackendStage::Threading::kCaller);
}

void RobotPipeline::send(double now_s, std::string peer, TeamMessage message) {
  outbox_.push_back({now_s, std::move(peer), std::move(message)});
}

std::vector<RobotPipeline::Outgoing> RobotPipeline::takeOutbox() {
  std::vector<Outgoing> out;
  out.swap(outbox_);
  return out;
}

void RobotPipeline::route(double now_s, const pr::MatcherStage::Output& out) {
  for (const auto& refusal : out.refused) refuse(refusal.kind);
  if (out.features) {
    broker_.ccir().countFeaturesSent();
    send(now_s, "", *out.features);
  }
  for (const auto& c : out.correspondences) broker_.onCorrespondences(c.peer, c.counts);
  verifications_ += out.verified;
  for (const double waited_s : out.waited_s) closure_waits_.emplace_back(now_s, waited_s);
  for (const auto& loop : out.loop_closures) {
    (loop.robot_to == name_ ? own_loops_ : inter_loops_) += 1;
    if (backend_->addOwnLoop(loop)) send(now_s, "", loop);
  }
}

void RobotPipeline::route(double now_s, const Broker::Output& out) {
  for (const auto& refusal : out.refused) refuse(refusal.kind);
  for (const auto& o : out.offers) send(now_s, o.requester, o);
  for (const auto& r : out.requests) send(now_s, r.provider, r);
  for (const auto& r : out.receipts) send(now_s, r.provider, r);
  for (const auto& [peer, scan] : out.scans) send(now_s, peer, scan);
}

void RobotPipeline::onKeyframe(double now_s, const SimKeyframe& keyframe) {
  const KeyframeId id = keyframe.decision.id;
  // Backend first: a loop closure found with this keyframe needs its node.
  backend_->add(backend::BackendStage::OwnKeyframe{name_, id, keyframe.stamp, keyframe.odom_pose});

  matcher_.addOwnTravel(keyframe.decision.travelled_m);
  pr::DescribedKeyframe described;
  route(now_s,
        matcher_.describeOwn(id, keyframe.stamp, *keyframe.cloud, keyframe.odom_pose, &described));
  route(now_s, matcher_.matchOwn(std::move(described)));

  const auto xyz = xyzOf(*keyframe.cloud);
  map_.addOwn(keyframe.stamp, xyz, keyframe.odom_pose);
  auto wire = std::make_shared<routing::WireScan>();
  wire->robot = name_;
  wire->id = id;
  wire->stamp = keyframe.stamp;
  wire->odom_pose = keyframe.odom_pose;
  wire->travelled_m = static_cast<float>(keyframe.decision.travelled_m);
  wire->rotated_rad = static_cast<float>(keyframe.decision.rotated_rad);
  std::string error;
  if (!measured("codec", [&] {
        return routing::encodeWireScan(*keyframe.cloud, broker_.ccir().params(), wire.get(),
                                       &error);
      })) {
    return refuse("keyframes");  // as the Broker nodelet drops it
  }
  const std::size_t bytes = serializedBytes(*wire);
  route(now_s, measured("footprint", [&] {
          return broker_.addKeyframe(id, keyframe.stamp, keyframe.odom_pose, *xyz, std::move(wire),
                                     bytes);
        }));
}

void RobotPipeline::onMessage(double now_s, const TeamMessage& message) {
  if (const auto* words = std::get_if<pr::KeyframeWords>(&message)) {
    route(now_s, matcher_.onTeammateWords(*words));
  } else if (const auto* offer = std::get_if<routing::Offer>(&message)) {
    route(now_s, broker_.onOffer(*offer));
  } else if (const auto* request = std::get_if<routing::Request>(&message)) {
    route(now_s, broker_.onRequest(*request, now_s));
  } else if (const auto* receipt = std::get_if<routing::Receipt>(&message)) {
    route(now_s, broker_.onReceipt(*receipt));
  } else if (const auto* loop = std::get_if<pose_graph::LoopClosureData>(&message)) {
    matcher_.onTeammateClosure(*loop);
    backend_->addTeammateLoop(*loop);
  } else {
    onScan(now_s, *std::get<std::shared_ptr<const routing::WireScan>>(message));
  }
}

void RobotPipeline::onScan(double now_s, const routing::WireScan& scan) {
  std::string error;
  const auto cloud = measured("codec", [&] {
    return routing::decodeWireScan(scan.points, scan.encoding, scan.point_count, scan.id, &error);
  });
  const auto out = broker_.onScan(scan.robot, scan.id, serializedBytes(scan),
                                  cloud ? std::nullopt : std::optional<std::string>(error));
  route(now_s, out);
  if (!out.refused.empty()) return;
  // On teammate_scans: the Backend, the Matcher and the Mapper take it.
  backend_->add(backend::BackendStage::PeerKeyframe{scan.robot, scan.id, scan.odom_pose});
  route(now_s, matcher_.onTeammateScan(scan.robot, scan.id, scan.stamp, *cloud, scan.odom_pose,
                                       scan.encoding == routing::ScanEncoding::kGmm));
  if (const auto why = map_.addPeer(scan.robot, scan.id, xyzOf(*cloud), scan.odom_pose)) {
    refuse("teammate_scans (not added)");
  }
}

void RobotPipeline::runTimers(double now_s) {
  if (optimisation_.due(now_s)) backend_->tick();
  if (map_update_.due(now_s)) map_.followPoses(now_s);
  if (offers_.due(now_s)) {
    route(now_s, measured("route", [&] { return broker_.runPeriod(now_s); }));
  }
}

void RobotPipeline::setLink(const std::string& peer, const routing::LinkState& state) {
  broker_.ccir().setLink(peer, state);
}

void RobotPipeline::route(const backend::BackendStage::Output& out) {
  const backend::BackendSnapshot& snapshot = out.snapshot;
  snapshot_ = snapshot;
  if (snapshot.poses.empty()) return;
  // As trajectory, team_transforms, team_keyframe_poses and keyframe_uncertainty carry it.
  std::vector<std::pair<Stamp, Pose3>> poses;
  for (std::size_t i = 0; i < snapshot.poses.size(); ++i) {
    poses.emplace_back(snapshot.stamps[i], snapshot.poses[i]);
  }
  broker_.ccir().setOptimizedPoses(poses);
  map_.setOptimizedPoses(poses);
  for (const auto& estimate : snapshot.team) {
    const auto& a = estimate.alignment;
    broker_.ccir().setTeamTransform(estimate.peer,
                                    a.found ? std::optional<Pose3>(a.transform) : std::nullopt);
    if (a.found) map_.setTeamTransform(estimate.peer, a.transform);
  }
  for (const auto& keyframes : snapshot.peer_keyframes) {
    std::vector<std::pair<KeyframeId, Pose3>> pairs;
    for (std::size_t i = 0; i < keyframes.ids.size(); ++i) {
      pairs.emplace_back(keyframes.ids[i], keyframes.poses[i]);
    }
    map_.setPeerPoses(keyframes.robot, pairs);
  }
  if (out.uncertainty) {
    for (std::size_t i = 0; i < snapshot.ids.size(); ++i) {
      broker_.ccir().setUncertainty(snapshot.ids[i], (*out.uncertainty)[i]);
    }
  }
}

}  // namespace ccir_mapping::core::runner
