#include "ccir_mapping/core/transport/peer_session.h"

#include <stdexcept>

#include "ccir_mapping/core/common/compression.h"

namespace ccir_mapping::core::transport {
namespace {

// TOPIC payload: length-prefixed strings and two flags.
void putString(std::vector<std::uint8_t>& out, const std::string& s) {
  const auto n = static_cast<std::uint32_t>(s.size());
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(n >> (8 * i)));
  out.insert(out.end(), s.begin(), s.end());
}

bool getString(const std::vector<std::uint8_t>& in, std::size_t& at, std::string& s) {
  if (in.size() - at < 4) return false;
  std::uint32_t n = 0;
  for (int i = 0; i < 4; ++i) n |= static_cast<std::uint32_t>(in[at + i]) << (8 * i);
  at += 4;
  if (in.size() - at < n) return false;
  s.assign(in.begin() + static_cast<std::ptrdiff_t>(at),
           in.begin() + static_cast<std::ptrdiff_t>(at + n));
  at += n;
  return true;
}

std::vector<std::uint8_t> encodeTopic(const TopicInfo& t) {
  std::vector<std::uint8_t> out;
  for (const auto* s : {&t.name, &t.type, &t.md5, &t.definition}) putString(out, *s);
  out.push_back(t.latched);
  out.push_back(t.reliable);
  out.push_back(t.compressed);
  return out;
}

bool decodeTopic(const std::vector<std::uint8_t>& in, TopicInfo& t) {
  std::size_t at = 0;
  for (auto* s : {&t.name, &t.type, &t.md5, &t.definition}) {
    if (!getString(in, at, *s)) return false;
  }
  if (in.size() - at != 3) return false;
  t.latched = in[at] != 0;
  t.reliable = in[at + 1] != 0;
  t.compressed = in[at + 2] != 0;
  return true;
}

// ACK payload: the topic (2 bytes) and the highest sequence delivered (8 bytes).
std::vector<std::uint8_t> encodeAck(std::uint16_t topic, std::uint64_t sequence) {
  std::vector<std::uint8_t> out = {static_cast<std::uint8_t>(topic),
                                   static_cast<std::uint8_t>(topic >> 8)};
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(sequence >> (8 * i)));
  return out;
}

std::uint64_t getU64(const std::vector<std::uint8_t>& in, std::size_t at) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < 8; ++i) value |= static_cast<std::uint64_t>(in[at + i]) << (8 * i);
  return value;
}

}  // namespace

// HELLO payload: the incarnation (8 bytes), the connection's nonce and the robot name.
std::vector<std::uint8_t> encodeHello(const Hello& hello) {
  std::vector<std::uint8_t> out;
  for (int i = 0; i < 8; ++i)
    out.push_back(static_cast<std::uint8_t>(hello.incarnation >> (8 * i)));
  out.insert(out.end(), hello.nonce.begin(), hello.nonce.end());
  out.insert(out.end(), hello.robot.begin(), hello.robot.end());
  return out;
}

std::optional<Hello> decodeHello(const std::vector<std::uint8_t>& payload) {
  constexpr std::size_t kFixed = 8 + kNonceBytes;
  if (payload.size() <= kFixed || payload.size() > kFixed + 255) return std::nullopt;
  Hello hello{std::string(payload.begin() + kFixed, payload.end()), getU64(payload, 0), {}};
  std::copy(payload.begin() + 8, payload.begin() + kFixed, hello.nonce.begin());
  return hello;
}

PeerSession::PeerSession(std::string own_robot, std::string peer_robot, std::string team_key,
                         const SessionParams& params, double now_s)
    : own_(std::move(own_robot)),
      peer_(std::move(peer_robot)),
      key_(std::move(team_key)),
      params_(params),
      scheduler_(params.budget_bytes_per_s, params.burst_bytes, params.fragment_bytes, now_s),
      decoder_(key_, params.max_message_bytes),
      reassembler_(params.max_message_bytes, 64),
      outbox_(params.max_unacknowledged_bytes) {
  scheduler_.setTopic(kSessionTopic, {Priority::kControl, QueuePolicy::kFifo, 0.0, 100000});
}

void PeerSession::announce(std::uint16_t id, double now_s) {
  // The announcement travels on the session topic; its sequence names the topic id.
  scheduler_.enqueue(kSessionTopic, encodeTopic(topics_[id - 1]), now_s, FrameType::kTopic, id);
}

std::uint16_t PeerSession::addTopic(const TopicInfo& topic, double now_s) {
  if (topics_.size() >= 0xfffe) throw std::invalid_argument("PeerSession: too many topics");
  topics_.push_back(topic);
  const auto id = static_cast<std::uint16_t>(topics_.size());
  scheduler_.setTopic(id, topic.policy);
  // Announced on every connection; now too if one is up (before any of its data).
  if (connected_) announce(id, now_s);
  return id;
}

void PeerSession::send(std::uint16_t topic, std::vector<std::uint8_t> message, double now_s) {
  if (topic == kSessionTopic || topic > topics_.size()) {
    throw std::invalid_argument("PeerSession: unknown topic");
  }
  const TopicInfo& info = topics_[topic - 1];
  if (message.size() > params_.max_message_bytes) {
    ++counters_.dropped_too_large;  // the peer would refuse it
    return;
  }
  if (info.compressed) message = compress(message);
  if (!connected_ && !info.reliable) {
    // Lost, except a latched topic's latest, which the next peer to say HELLO gets.
    if (info.latched) latched_[topic] = {0, std::move(message)};
    ++counters_.dropped_not_connected;
    return;
  }
  // Kept for a resend: reliable messages until acknowledged, latched ones' latest for a peer
  // that restarts. With no connection up, a reliable message waits in the outbox alone: the
  // next connection sends all it holds (its bound, not the topic's max_queued, limits a long
  // outage).
  std::vector<std::uint8_t> copy;
  if (info.reliable || info.latched) copy = message;
  const std::uint64_t sequence = connected_ ? scheduler_.enqueue(topic, std::move(message), now_s)
                                            : scheduler_.nextSequence(topic);
  if (info.latched) latched_[topic] = {sequence, copy};
  if (info.reliable) outbox_.sent(topic, sequence, std::move(copy));
}

void PeerSession::connected(double now_s) {
  scheduler_.clear();
  decoder_ = FrameDecoder(key_, params_.max_message_bytes);
  reassembler_ = Reassembler(params_.max_message_bytes, 64);
  peer_topics_.clear();
  peer_topic_bytes_ = 0;
  peer_said_hello_ = false;
  hello_sent_ = false;
  out_key_.clear();
  unconfirmed_hello_.reset();
  reason_.clear();
  nonce_ = drawNonce();
  scheduler_.enqueue(kSessionTopic, encodeHello({own_, params_.incarnation, nonce_}), now_s,
                     FrameType::kHello);
  connected_ = true;
  for (std::size_t i = 0; i < topics_.size(); ++i)
    announce(static_cast<std::uint16_t>(i + 1), now_s);
  for (auto& m : outbox_.unacknowledged()) {
    scheduler_.enqueue(m.topic, std::move(m.bytes), now_s, FrameType::kData, m.sequence);
  }
}

std::pair<std::size_t, std::size_t> PeerSession::inOutbox(Priority priority) const {
  std::pair<std::size_t, std::size_t> waiting{0, 0};
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    if (topics_[i].policy.priority != priority) continue;
    waiting.first += outbox_.messages(static_cast<std::uint16_t>(i + 1));
    waiting.second += outbox_.bytes(static_cast<std::uint16_t>(i + 1));
  }
  return waiting;
}

void PeerSession::disconnected() {
  connected_ = false;
  scheduler_.clear();
}

void PeerSession::keepAlive(double now_s) {
  if (!connected_ || scheduler_.queued(Priority::kControl) + scheduler_.queued(Priority::kBulk))
    return;
  // An acknowledgement of nothing (session topic, sequence 0).
  scheduler_.enqueue(kSessionTopic, encodeAck(kSessionTopic, 0), now_s, FrameType::kAck);
}

std::vector<std::uint8_t> PeerSession::output(double now_s, std::size_t max_frames) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t n = 0; n < max_frames; ++n) {
    // Our HELLO (queued first on a new connection) goes alone until the peer's has come.
    if (hello_sent_ && out_key_.empty()) break;
    const auto frame = scheduler_.next(now_s);
    if (!frame) break;
    const auto encoded = encodeFrame(*frame, hello_sent_ ? out_key_ : key_);
    hello_sent_ = true;
    bytes.insert(bytes.end(), encoded.begin(), encoded.end());
  }
  return bytes;
}

bool PeerSession::refuse(std::string reason) {
  reason_ = std::move(reason);
  return false;
}

bool PeerSession::greet(const std::vector<std::uint8_t>& payload, double now_s) {
  if (peer_said_hello_) return refuse("a second HELLO");
  const auto hello = decodeHello(payload);
  if (!hello) return refuse("a malformed HELLO");
  if (hello->robot != peer_)
    return refuse("the peer says it is '" + hello->robot + "', not " + peer_);
  peer_said_hello_ = true;
  decoder_.setKey(linkKey(key_, hello->nonce, nonce_));
  out_key_ = linkKey(key_, nonce_, hello->nonce);
  unconfirmed_hello_ = hello;
  // A frame under the new key at once, so that the peer can take our HELLO as fresh.
  scheduler_.enqueue(kSessionTopic, encodeAck(kSessionTopic, 0), now_s, FrameType::kAck);
  return true;
}

void PeerSession::welcome(const Hello& hello, double now_s) {
  const bool restarted = peer_incarnation_ != hello.incarnation;
  // A restarted peer's sequences start again.
  if (restarted && peer_incarnation_) {
    filter_ = SequenceFilter();
    ++counters_.peer_restarts;
  }
  peer_incarnation_ = hello.incarnation;
  // The latest latched messages: reliable ones for a new peer process (unless waiting in the
  // outbox anyway), unreliable ones on every connection (they may have been lost with the last).
  for (auto& [topic, latest] : latched_) {
    const bool resend =
        topics_[topic - 1].reliable ? restarted && !outbox_.pending(topic, latest.first) : true;
    if (resend) scheduler_.enqueue(topic, latest.second, now_s, FrameType::kData, latest.first);
  }
}

bool PeerSession::input(const std::uint8_t* data, std::size_t size, double now_s,
                        std::vector<InboxMessage>& inbox) {
  if (!reason_.empty()) return false;
  decoder_.feed(data, size);
  counters_.bytes_received += size;
  std::map<std::uint16_t, std::uint64_t> to_acknowledge;
  while (auto frame = decoder_.next()) {
    counters_.last_heard_s = now_s;
    if (!peer_said_hello_ && frame->type != FrameType::kHello) {
      return refuse("the peer did not say HELLO first");
    }
    if (unconfirmed_hello_ && frame->type != FrameType::kHello) {
      welcome(*unconfirmed_hello_, now_s);  // this frame passed the connection's key
      unconfirmed_hello_.reset();
    }
    switch (frame->type) {
      case FrameType::kHello:
        if (!greet(frame->payload, now_s)) return false;
        break;
      case FrameType::kTopic: {
        TopicInfo t;
        if (!decodeTopic(frame->payload, t) || frame->sequence == 0 || frame->sequence > 0xffff) {
          return refuse("a malformed topic announcement");
        }
        auto& announced = peer_topics_[static_cast<std::uint16_t>(frame->sequence)];
        peer_topic_bytes_ = peer_topic_bytes_ - announced.second + frame->payload.size();
        announced = {t, frame->payload.size()};
        if (peer_topics_.size() > kMaxPeerTopics || peer_topic_bytes_ > kMaxPeerTopicBytes) {
          return refuse("more topic announcements than a peer may make");
        }
        break;
      }
      case FrameType::kAck: {
        const auto& p = frame->payload;
        if (p.size() != 10) return refuse("a malformed acknowledgement");
        outbox_.acknowledge(static_cast<std::uint16_t>(p[0] | (p[1] << 8)), getU64(p, 2));
        break;
      }
      case FrameType::kData: {
        const auto announced = peer_topics_.find(frame->topic);
        if (announced == peer_topics_.end()) return refuse("data on a topic never announced");
        const TopicInfo& topic = announced->second.first;
        auto message = reassembler_.add(*frame);
        if (!message) break;
        if (topic.reliable) {
          if (!filter_.accept(peer_, frame->topic, frame->sequence)) break;
          to_acknowledge[frame->topic] = filter_.delivered(peer_, frame->topic);
        }
        if (topic.compressed) {
          message = decompress(*message, params_.max_message_bytes);
          if (!message) return refuse("a message that does not decompress");
        }
        ++counters_.messages_received;
        inbox.push_back({topic, std::move(*message)});
        break;
      }
    }
  }
  if (decoder_.error() != FrameError::kNone) return refuse(toString(decoder_.error()));
  for (const auto& [topic, sequence] : to_acknowledge) {
    scheduler_.enqueue(kSessionTopic, encodeAck(topic, sequence), now_s, FrameType::kAck);
  }
  return true;
}

}  // namespace ccir_mapping::core::transport
