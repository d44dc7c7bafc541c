#include "ccir_mapping/core/transport/bridge_stage.h"

#include <chrono>
#include <random>
#include <stdexcept>
#include <thread>

#include "bridge_connections.h"
#include "bridge_context.h"
#include "bridge_pump.h"

namespace ccir_mapping::core::transport {
namespace {

std::uint64_t drawIncarnation() {
  std::random_device device;
  return (static_cast<std::uint64_t>(device()) << 32) ^ device() ^
         static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
}

}  // namespace

struct BridgeStage::Impl {
  Impl(const BridgeParams& params, const std::string& own, InboxHandler on_message,
       LogHandler on_log, Clock clock)
      : context(params, own, std::move(on_message), std::move(on_log), std::move(clock)),
        pump(context,
             [this](BridgeLink& link, const std::string& why, const std::string& refusal) {
               connections.close(link, why, refusal);
             }),
        connections(context, pump) {}

  BridgeContext context;
  BridgePump pump;
  BridgeConnections connections;
  /// Each topic as announced to the peers, and its id on each link.
  std::map<std::string, std::pair<TopicInfo, std::vector<std::uint16_t>>> topics;
  std::uint64_t type_changed = 0;
  std::thread thread;
};

BridgeStage::BridgeStage(const BridgeParams& params, const std::string& own_robot,
                         InboxHandler on_message, LogHandler on_log, Clock clock) {
  const auto errors = params.validate(own_robot);
  if (!errors.empty()) throw std::invalid_argument("Bridge: " + errors.front());
  impl_ = std::make_unique<Impl>(params, own_robot, std::move(on_message), std::move(on_log),
                                 std::move(clock));
  BridgeContext& context = impl_->context;
  const double t = context.now();
  SessionParams session;
  session.budget_bytes_per_s = params.budget_bytes_per_s;
  session.burst_bytes = static_cast<std::size_t>(params.burst_bytes);
  session.fragment_bytes = static_cast<std::size_t>(params.fragment_bytes);
  session.max_message_bytes = static_cast<std::size_t>(params.max_message_bytes);
  session.incarnation = drawIncarnation();
  const auto total = std::make_shared<TokenBucket>(params.total_budget_bytes_per_s,
                                                   static_cast<double>(params.burst_bytes), t);
  for (const PeerConfig& peer : params.peers) {
    auto link = std::unique_ptr<BridgeLink>(
        new BridgeLink{peer, params.listen_port == 0 || own_robot < peer.name,
                       PeerSession(own_robot, peer.name, params.team_key, session, t)});
    link->session.shareBucket(total);
    link->dial_timer = std::make_unique<asio::steady_timer>(context.io);
    link->read_bucket = std::make_unique<TokenBucket>(
        BridgeStage::kReadShare * params.budget_bytes_per_s,
        BridgeStage::kReadShare * params.burst_bytes + BridgeStage::kReadChunkBytes, t);
    link->read_timer = std::make_unique<asio::steady_timer>(context.io);
    context.links.push_back(std::move(link));
  }
}

BridgeStage::~BridgeStage() {
  if (impl_->thread.joinable()) {
    impl_->context.io.stop();
    impl_->thread.join();
  }
}

void BridgeStage::start() {
  Impl& m = *impl_;
  if (m.context.params.listen_port != 0) m.connections.listen();
  {
    std::lock_guard<std::mutex> lock(m.context.mutex);
    m.connections.dialAll();
    m.pump.keepAlive();
  }
  m.thread = std::thread([&m] { m.context.io.run(); });
}

bool BridgeStage::publish(const TopicInfo& topic, std::vector<std::uint8_t> message,
                          const std::string& only_peer) {
  Impl& m = *impl_;
  auto& links = m.context.links;
  std::lock_guard<std::mutex> lock(m.context.mutex);
  const double t = m.context.now();
  auto known = m.topics.find(topic.name);
  if (known == m.topics.end()) {
    std::vector<std::uint16_t> ids;
    for (auto& link : links) ids.push_back(link->session.addTopic(topic, t));
    known = m.topics.emplace(topic.name, std::make_pair(topic, ids)).first;
  } else if (known->second.first.md5 != topic.md5) {
    ++m.type_changed;
    return false;
  }
  std::vector<std::size_t> to;
  for (std::size_t i = 0; i < links.size(); ++i) {
    if (only_peer.empty() || links[i]->config.name == only_peer) to.push_back(i);
  }
  for (std::size_t n = 0; n < to.size(); ++n) {
    // The last link takes the message itself, the others a copy.
    auto bytes = n + 1 == to.size() ? std::move(message) : message;
    links[to[n]]->session.send(known->second.second[to[n]], std::move(bytes), t);
  }
  asio::post(m.context.io, [&m] {
    std::lock_guard<std::mutex> lock(m.context.mutex);
    m.pump.pump();
  });
  return true;
}

std::vector<LinkReport> BridgeStage::reports() {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.context.mutex);
  const double t = m.context.now();
  std::vector<LinkReport> reports;
  for (const auto& link : m.context.links) {
    LinkReport r;
    r.peer = link->config.name;
    r.connected = static_cast<bool>(link->socket);
    r.address =
        r.connected ? link->address : link->config.host + ":" + std::to_string(link->config.port);
    r.sent = link->session.counters();
    r.received = link->session.sessionCounters();
    r.queued_control = link->session.queued(Priority::kControl);
    r.queued_bulk = link->session.queued(Priority::kBulk);
    r.queued_control_bytes = link->session.queuedBytes(Priority::kControl);
    r.queued_bulk_bytes = link->session.queuedBytes(Priority::kBulk);
    r.available_tokens_bytes = link->session.availableTokens(t);
    r.silent_s = r.received.last_heard_s < 0 ? -1.0 : t - r.received.last_heard_s;
    r.at_s = t;
    r.drops = link->refused;
    r.drops["queue_full"] = r.sent.dropped_queue_full;
    r.drops["too_old"] = r.sent.dropped_expired;
    r.drops["replaced"] = r.sent.replaced;
    r.drops["not_connected"] = r.received.dropped_not_connected;
    r.drops["too_large"] = r.received.dropped_too_large;
    r.drops["given_up"] = link->session.givenUp();
    r.drops["duplicate"] = link->session.duplicatesDropped();
    r.drops["missing"] = link->session.missing();
    r.drops["type_changed"] = m.type_changed;
    reports.push_back(std::move(r));
  }
  if (!m.connections.refusedUnidentified().empty()) {
    LinkReport r;
    for (const auto& [reason, count] : m.connections.refusedUnidentified())
      r.drops["refused: " + reason] = count;
    reports.push_back(std::move(r));
  }
  return reports;
}

}  // namespace ccir_mapping::core::transport
