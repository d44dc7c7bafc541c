#include "ccir_mapping/core/runner/robot_pipeline.h"

#include <pcl/common/io.h>

#include "ccir_mapping/core/common/cpu_time.h"
#include "ccir_mapping/core/routing/scan_encoding.h"

namespace ccir_mapping::core::runner {

namespace pr = place_recognition;
using team::TeamGraphWorker;

namespace {

using KeyframeCloud = pcl::PointCloud<pcl::PointXYZINormal>;

/// The wire form the Broker sends (as conversions::toSharedScan makes it of a Keyframe).
std::shared_ptr<const WireScan> toWireScan(const std::string& robot, const SimKeyframe& keyframe,
                                           const routing::BrokerParams& params) {
  std::string error;
  auto encoded = routing::encodeKeyframeScan(*keyframe.cloud, params, &error);
  if (!encoded) throw std::runtime_error("cannot encode keyframe of " + robot + ": " + error);
  auto scan = std::make_shared<WireScan>();
  scan->robot = robot;
  scan->id = keyframe.decision.id;
  scan->stamp = keyframe.stamp;
  scan->odom_pose = keyframe.odom_pose;
  scan->travelled_m = static_cast<float>(keyframe.decision.travelled_m);
  scan->rotated_rad = static_cast<float>(keyframe.decision.rotated_rad);
  scan->encoding = params.scan_encoding;
  scan->point_count = static_cast<std::uint32_t>(keyframe.cloud->size());
  scan->points = std::move(*encoded);
  return scan;
}

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

void RobotPipeline::addCpu(const char* stage, double seconds) {
  std::lock_guard<std::mutex> lock(cpu_mutex_);
  stage_cpu_[stage] += seconds;
}

std::map<std::string, double> RobotPipeline::stageCpu() const {
  std::lock_guard<std::mutex> lock(cpu_mutex_);
  return stage_cpu_;
}

double RobotPipeline::backgroundCpu() const {
  std::lock_guard<std::mutex> lock(cpu_mutex_);
  const auto it = stage_cpu_.find("rebuild");
  return it == stage_cpu_.end() ? 0.0 : it->second;
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
      matcher_(params.matcher, std::move(model)),
      map_(name_, params.mapper,
           {[this](const char* stage, const std::function<void()>& work) { measured(stage, work); },
            {}}),
      broker_(name_, std::move(peers), params.broker, params.mapper),
      offers_{params.broker.offer_period_s, start_s + phase * params.broker.offer_period_s},
      optimisation_{params.backend.optimize_period_s,
                    start_s + phase * params.backend.optimize_period_s},
      map_update_{params.mapper.publish_period_s,
                  start_s + phase * params.mapper.publish_period_s} {
  information::SharedMap::registerMap(name_, map_.map());
  TeamGraphWorker::Hooks hooks;
  hooks.run = [this](const auto& batch) { return measured("optimise", batch); };
  hooks.optimized = [this](const auto& snapshot, const auto& graph) {
    onOptimized(snapshot, graph);
  };
  hooks.refused = [this](TeamGraphWorker::Refusal why, const std::string&) {
    refuse(TeamGraphWorker::reportOf(why).flow);
  };
  backend_ =
      std::make_unique<TeamGraphWorker>(std::make_unique<team::TeamGraph>(name_, params.backend),
                                        hooks, TeamGraphWorker::Threading::kCaller);
}

void RobotPipeline::send(double now_s, std::string peer, TeamMessage message) {
  outbox_.push_back({now_s, std::move(peer), std::move(message)});
}

std::vector<RobotPipeline::Outgoing> RobotPipeline::takeOutbox() {
  std::vector<Outgoing> out;
  out.swap(outbox_);
  return out;
}

void RobotPipeline::emit(double now_s, const Broker::Output& out) {
  for (const auto& refusal : out.refused) refuse(refusal.kind);
  const auto control = [&](const std::string& peer, TeamMessage message) {
    broker_.ccir().addControlBytes(peer, serializedBytes(message));
    send(now_s, peer, std::move(message));
  };
  for (const auto& o : out.offers) control(o.requester, o);
  for (const auto& r : out.requests) control(r.provider, r);
  for (const auto& r : out.receipts) control(r.provider, r);
  for (const auto& [peer, scan] : out.scans) send(now_s, peer, scan);
}

void RobotPipeline::onKeyframe(double now_s, const SimKeyframe& keyframe) {
  const KeyframeId id = keyframe.decision.id;
  // Backend first: a loop closure found with this keyframe needs its node.
  backend_->add(TeamGraphWorker::OwnKeyframe{name_, id, keyframe.stamp, keyframe.odom_pose});

  // Matcher: word set to every teammate, c_k with the teammates' word sets, loop closures.
  matcher_.addOwnTravel(keyframe.decision.travelled_m);
  auto described = measured("describe", [&] {
    return matcher_.describeOwn(id, keyframe.stamp, *keyframe.cloud, keyframe.odom_pose);
  });
  broker_.ccir().countFeaturesSent();
  send(now_s, "",
       WordsMessage{name_, id, keyframe.stamp, matcher_.model().vocabulary.hash(), described.words,
                    static_cast<std::uint32_t>(described.scan.features.descriptors.size())});
  for (const auto& c : matcher_.teammateCorrespondences(described.words)) {
    broker_.ccir().setCorrespondences(c.robot, id, c.count);
  }
  const auto kept = measured("match", [&] { return matcher_.matchKeptScans(described); });
  const auto candidates = measured("match", [&] { return matcher_.addOwn(std::move(described)); });
  closeLoop(now_s, kept, name_, id);
  closeLoop(now_s, candidates, name_, id);

  // Mapper and Broker.
  const auto xyz = xyzOf(*keyframe.cloud);
  map_.addOwn(keyframe.stamp, xyz, keyframe.odom_pose);
  auto wire =
      measured("codec", [&] { return toWireScan(name_, keyframe, broker_.ccir().params()); });
  const std::size_t bytes = serializedBytes(*wire);
  emit(now_s, measured("footprint", [&] {
         return broker_.addKeyframe(id, keyframe.stamp, keyframe.odom_pose, *xyz, std::move(wire),
                                    bytes);
       }));
}

void RobotPipeline::closeLoop(double now_s, const std::vector<pr::MatchCandidate>& candidates,
                              const std::string& query_robot, KeyframeId query,
                              const std::optional<Pose3>& query_odom_pose) {
  const pr::MatchCandidate* best = pr::bestAccepted(candidates);
  if (!best) return;
  auto loop = matcher_.loopClosure(name_, *best, query_robot, query, query_odom_pose);
  (loop.robot_to == name_ ? own_loops_ : inter_loops_) += 1;
  if (backend_->addOwnLoop(loop)) send(now_s, "", std::move(loop));
}

void RobotPipeline::onMessage(double now_s, const TeamMessage& message) {
  if (const auto* words = std::get_if<WordsMessage>(&message)) {
    if (const auto problem = matcher_.wordsProblem(words->vocabulary_hash, words->words)) {
      return refuse("features (" + problem->kind + ")");
    }
    for (const auto& [id, c] : matcher_.correspondences(words->words)) {
      broker_.ccir().setCorrespondences(words->robot, id, c);
    }
    matcher_.keepTeammateWords(words->robot, words->id, words->words);
  } else if (const auto* offer = std::get_if<routing::Offer>(&message)) {
    emit(now_s, broker_.onOffer(*offer));
  } else if (const auto* request = std::get_if<routing::Request>(&message)) {
    emit(now_s, broker_.onRequest(*request, now_s));
  } else if (const auto* receipt = std::get_if<routing::Receipt>(&message)) {
    emit(now_s, broker_.onReceipt(*receipt));
  } else if (const auto* loop = std::get_if<backend::LoopClosureData>(&message)) {
    backend_->addTeammateLoop(*loop);
  } else {
    onScan(now_s, *std::get<std::shared_ptr<const WireScan>>(message));
  }
}

void RobotPipeline::onScan(double now_s, const WireScan& scan) {
  std::string error;
  // As conversions::toKeyframe reads a SharedScan.
  const auto cloud = measured("codec", [&] {
    return routing::decodeKeyframeScan(scan.points, scan.encoding, scan.point_count,
                                       scan.point_count, scan.id, &error);
  });
  const auto out = broker_.onScan(scan.robot, scan.id, serializedBytes(scan),
                                  cloud ? std::nullopt : std::optional<std::string>(error));
  emit(now_s, out);
  if (!out.refused.empty()) return;
  // Published on teammate_scans: Backend, Matcher and Mapper take it.
  backend_->add(TeamGraphWorker::PeerKeyframe{scan.robot, scan.id, scan.odom_pose});
  auto described = measured("describe", [&] {
    return matcher_.describeTeammate(scan.id, scan.stamp, *cloud, scan.odom_pose,
                                     scan.encoding == routing::ScanEncoding::kGmm);
  });
  closeLoop(now_s, measured("match", [&] { return matcher_.matchTeammate(described); }), scan.robot,
            scan.id, described.odom_pose);
  matcher_.keepTeammateScan(scan.robot, std::move(described));
  if (const auto why = map_.addPeer(scan.robot, scan.id, xyzOf(*cloud), scan.odom_pose)) {
    refuse("teammate_scans (not added)");
  }
}

void RobotPipeline::runTimers(double now_s) {
  if (optimisation_.due(now_s)) backend_->tick();
  if (map_update_.due(now_s)) {
    map_.rebuildIfDue(now_s);
    map_.waitForRebuild();  // here, not beside the next steps: a run must not depend on timing
  }
  if (offers_.due(now_s)) {
    emit(now_s, measured("route", [&] { return broker_.runPeriod(now_s); }));
  }
}

void RobotPipeline::setLink(const std::string& peer, const routing::LinkState& state) {
  broker_.ccir().setLink(peer, state);
}

void RobotPipeline::onOptimized(const team::BackendSnapshot& snapshot,
                                const team::TeamGraph& graph) {
  snapshot_ = snapshot;
  if (snapshot.poses.empty()) return;
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
  if (const auto variances =
          measured("uncertainty", [&] { return graph.positionVariances(snapshot.ids); })) {
    for (std::size_t i = 0; i < snapshot.ids.size(); ++i) {
      broker_.ccir().setUncertainty(snapshot.ids[i], (*variances)[i]);
    }
  }
}

}  // namespace ccir_mapping::core::runner
